#include "penumbra/scene/mesh_file_checks.h"

#include <cctype>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "penumbra/core/error.h"

namespace penumbra {

namespace fs = std::filesystem;

namespace {

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// A header line for a message: printable ASCII only, at most 60 characters.
std::string abbreviate_line(std::string_view line) {
  std::string out;
  for (char c : line) {
    if (out.size() >= 60) return out + "...";
    out += (c >= 32 && c < 127) ? c : '?';
  }
  return out;
}

// A decimal count of at most 19 digits (no sign); false for anything else.
bool parse_count(std::string_view text, uint64_t* out) {
  if (text.empty() || text.size() > 19) return false;
  uint64_t v = 0;
  for (char c : text) {
    if (c < '0' || c > '9') return false;
    v = v * 10 + static_cast<uint64_t>(c - '0');
  }
  *out = v;
  return true;
}

std::vector<std::string_view> split_words(std::string_view line) {
  std::vector<std::string_view> words;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    size_t j = i;
    while (j < line.size() && line[j] != ' ' && line[j] != '\t') ++j;
    if (j > i) words.push_back(line.substr(i, j - i));
    i = j;
  }
  return words;
}

// Bytes of one binary PLY scalar (0 for an unknown type name).
int ply_type_size(std::string_view type) {
  if (type == "char" || type == "uchar" || type == "int8" || type == "uint8") return 1;
  if (type == "short" || type == "ushort" || type == "int16" || type == "uint16") return 2;
  if (type == "int" || type == "uint" || type == "int32" || type == "uint32" || type == "float" || type == "float32")
    return 4;
  if (type == "double" || type == "float64") return 8;
  return 0;
}

// PLY (Turk's format as Assimp reads it): "ply", a format line, then only element,
// property, comment and obj_info lines up to "end_header". Assimp 5.2 loops forever on
// some malformed headers (one that never reaches end_header, a mistyped magic or format
// line it half accepts) and reserves memory for every declared element before reading
// one, so the header is checked in full and each element's declared count against the
// fewest bytes its entries can take: the sizes of its properties in a binary file (a list
// at least its count), two bytes per property ("0 ") in an ASCII one.
void check_ply(const fs::path& path, std::ifstream& f, uint64_t file_size) {
  const std::string name = path.string();
  std::string line;
  std::getline(f, line);
  if (!line.empty() && line.back() == '\r') line.pop_back();
  if (line != "ply") throw Error("{}: not a PLY file (the first line must be \"ply\")", name);
  struct Element {
    std::string name;
    uint64_t count = 0;
    uint64_t min_bytes = 0;  // per entry
    int properties = 0;
  };
  std::vector<Element> elements;
  bool ascii = false;
  const auto malformed = [&](const std::string& l) {
    return Error("{}: malformed PLY header line \"{}\"", name, abbreviate_line(l));
  };
  for (int lines = 0; lines < 10000 && std::getline(f, line); ++lines) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line == "end_header") {
      const std::streamoff at = f.tellg();
      const uint64_t remaining = at < 0 ? 0 : file_size - std::min<uint64_t>(file_size, static_cast<uint64_t>(at));
      for (const Element& e : elements) {
        if (e.count > 0 && e.properties == 0)
          throw Error("{}: PLY element \"{}\" declares {} entries but no properties", name, abbreviate_line(e.name),
                      e.count);
      }
      // In order: each element's entries follow the previous element's.
      uint64_t need = 0;
      for (const Element& e : elements) {
        const uint64_t bytes = e.min_bytes * e.count;  // < 8000 * 2^32: no overflow
        need += bytes;
        if (need > remaining + (ascii ? 1 : 0))
          throw Error("{}: PLY header declares {} \"{}\" entries, more than the {} bytes after the header can hold",
                      name, e.count, abbreviate_line(e.name), remaining);
      }
      return;
    }
    if (lines == 0) {
      if (line == "format ascii 1.0") {
        ascii = true;
      } else if (line != "format binary_little_endian 1.0" && line != "format binary_big_endian 1.0") {
        throw Error("{}: malformed PLY header line \"{}\" (expected the format line)", name, abbreviate_line(line));
      }
      continue;
    }
    const std::vector<std::string_view> w = split_words(line);
    if (w.empty()) throw malformed(line);
    if (w[0] == "element") {
      uint64_t count = 0;
      if (w.size() != 3 || !parse_count(w[2], &count)) throw malformed(line);
      if (count > std::numeric_limits<uint32_t>::max())
        throw Error("{}: PLY element \"{}\" declares {} entries (at most {})", name, abbreviate_line(w[1]), count,
                    std::numeric_limits<uint32_t>::max());
      elements.push_back({std::string(w[1]), count, 0, 0});
    } else if (w[0] == "property") {
      if (elements.empty()) throw Error("{}: PLY property line \"{}\" before any element", name, abbreviate_line(line));
      Element& e = elements.back();
      if (e.properties >= 1000) throw Error("{}: PLY element \"{}\" has over 1000 properties", name, abbreviate_line(e.name));
      // "property TYPE NAME" or "property list COUNT_TYPE ITEM_TYPE NAME".
      const bool list = w.size() == 5 && w[1] == "list";
      if (!list && w.size() != 3) throw malformed(line);
      const int size = ply_type_size(w[list ? 2 : 1]);
      if (size == 0 || (list && ply_type_size(w[3]) == 0)) throw malformed(line);
      e.min_bytes += ascii ? 2 : static_cast<uint64_t>(size);
      ++e.properties;
    } else if (w[0] != "comment" && w[0] != "obj_info") {
      throw malformed(line);
    }
  }
  throw Error("{}: malformed PLY header (no end_header line)", name);
}

// OFF, read as Assimp 5.2's OFFLoader reads it (so the counts checked are the counts it
// allocates): comment lines ('#') and blank space skipped, an optional keyword
// ([ST][C][N][4][n]OFF, the counts may follow it without a space, a dimension comes first
// for nOFF), then the vertex and face counts as unsigned 32-bit numbers that wrap on
// overflow. Assimp allocates every declared vertex and face before reading the first; each
// takes at least one line, so the counts must not exceed the bytes left.
void check_off(const fs::path& path, std::ifstream& f, uint64_t file_size) {
  std::string head(static_cast<size_t>(std::min<uint64_t>(file_size, 1 << 16)), '\0');
  f.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<size_t>(f.gcount()));
  size_t at = 0;
  const auto is = [&](char c) { return at < head.size() && head[at] == c; };
  const auto skip_blank = [&] {
    while (at < head.size() && (head[at] == ' ' || head[at] == '\t' || head[at] == '\n' || head[at] == '\r')) ++at;
  };
  const auto next_token = [&] {
    skip_blank();
    while (is('#')) {
      while (at < head.size() && head[at] != '\n') ++at;
      skip_blank();
    }
  };
  // Assimp's strtoul10: leading digits, in 32-bit arithmetic that wraps.
  const auto read_count = [&] {
    uint32_t v = 0;
    for (; at < head.size() && head[at] >= '0' && head[at] <= '9'; ++at) v = v * 10u + uint32_t(head[at] - '0');
    return v;
  };
  next_token();
  if (head.compare(at, 2, "ST") == 0) at += 2;
  if (is('C')) ++at;
  if (is('N')) ++at;
  if (is('4')) ++at;
  const bool dimension = is('n');
  if (dimension) ++at;
  if (head.compare(at, 3, "OFF") == 0) at += 3;
  next_token();
  if (dimension) {
    read_count();
    next_token();
  }
  const uint64_t vertices = read_count();
  next_token();
  const uint64_t faces = read_count();
  const uint64_t remaining = file_size - std::min<uint64_t>(file_size, at);
  if (vertices + faces > remaining)
    throw Error("{}: OFF header declares {} vertices and {} faces, more than the {} bytes after it can hold",
                path.string(), vertices, faces, remaining);
}

// Binary STL: an 80-byte header, a 32-bit triangle count, 50 bytes per triangle. Assimp
// 5.2 takes a file for binary when 84 + 50 n equals its size in 32-bit arithmetic, which
// wraps: a 134-byte file declaring 85,899,346 triangles passes, and Assimp allocates 3 GB
// and reads past the end of its buffer.
void check_stl(const fs::path& path, std::ifstream& f, uint64_t file_size) {
  if (file_size < 84) return;
  unsigned char header[84];
  if (!f.read(reinterpret_cast<char*>(header), 84)) return;
  const uint32_t n = uint32_t(header[80]) | uint32_t(header[81]) << 8 | uint32_t(header[82]) << 16 |
                     uint32_t(header[83]) << 24;
  const uint32_t wrapped = n * 50u + 84u;
  if (wrapped == file_size && 84 + uint64_t(n) * 50 != file_size)
    throw Error("{}: binary STL header declares {} triangles, which need {} bytes; the file has {}", path.string(), n,
                84 + uint64_t(n) * 50, file_size);
}

}  // namespace

void check_mesh_file_header(const fs::path& path) {
  std::error_code ec;
  const uint64_t size = fs::file_size(path, ec);
  if (ec) return;  // Assimp reports what it cannot read
  std::ifstream f(path, std::ios::binary);
  if (!f) return;
  const std::string ext = lower(path.extension().string());
  if (ext == ".off") return check_off(path, f, size);
  if (ext == ".stl") return check_stl(path, f, size);
  // PLY: by extension, or by a first line that starts like PLY in any letter case (Assimp
  // reads those whatever the file is called).
  char magic[3] = {0, 0, 0};
  f.read(magic, 3);
  f.clear();
  f.seekg(0);
  if (ext == ".ply" || lower(std::string(magic, 3)) == "ply") {
    if (size == 0) return;  // empty: Assimp reports it
    return check_ply(path, f, size);
  }
}

}  // namespace penumbra
