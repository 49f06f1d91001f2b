#include "penumbra/scene/mesh_file_checks.h"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

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

// An ASCII PLY body's list counts: Assimp 5.2 reserves a list's items from its count before
// reading them, so a count of 10^19 in a 300-byte file made it allocate 13 GB (fuzz_mesh). Each
// count must be an unsigned integer no larger than the items the rest of the file can hold (two
// bytes an item, "0 "). Walks the entries as Assimp reads them: one line each, split as its
// line reader splits them (below), and none at all for an element whose name it does not know
// (vertex, face, tristrips, edge, material): it reads such an element's count from where the name starts,
// which is 0 for a name that does not start with a digit (those are refused below). A walk of
// the declared counts instead let a face's list count be read from an unknown element's first
// line, 3.8 billion items (fuzz_mesh, 2026-12-07). Stops where the file ends.
template <class Element>
void check_ply_ascii_lists(const std::string& name, std::ifstream& f, const std::vector<Element>& elements,
                           uint64_t remaining, bool at_line_end) {
  // Assimp 5.2's IOStreamBuffer::getNextLine: a line ends at '\r', '\n', '\f' or '\0', which it
  // consumes; a call that starts on a line end first skips past the next '\n' (so one blank
  // line of a "\n" file is skipped, while a "\r\n" file's blank line is an empty entry); a line
  // the file ends inside is not read. The stream starts where Assimp's does: on the header's
  // last line end (`at_line_end`: a "\r\n" header ends on its '\n').
  const auto line_end = [](int c) { return c == '\r' || c == '\n' || c == '\f' || c == '\0'; };
  std::string line;
  const auto next_line = [&]() {
    int c = f.peek();
    if (c == EOF) return false;
    if (line_end(c)) {
      while ((c = f.get()) != EOF && c != '\n') {
      }
      if (c == EOF || f.peek() == EOF) return false;
    }
    line.clear();
    while ((c = f.get()) != EOF && !line_end(c)) line += static_cast<char>(c);
    return c != EOF;
  };
  if (at_line_end) f.seekg(-1, std::ios::cur);
  for (const Element& e : elements) {
    const uint64_t entries = e.known ? e.count : 0;
    const bool has_list = std::find(e.lists.begin(), e.lists.end(), true) != e.lists.end();
    for (uint64_t i = 0; i < entries; ++i) {
      if (!next_line()) return;  // short files are Assimp's to refuse
      if (!has_list) continue;
      const std::vector<std::string_view> tokens = split_words(line);
      size_t t = 0;
      for (const bool list : e.lists) {
        if (t >= tokens.size()) break;
        const std::string_view token = tokens[t++];
        if (!list) continue;
        uint64_t items = 0;
        if (!parse_count(token, &items) || items > remaining / 2)
          throw Error("{}: PLY element \"{}\" entry {}: list count \"{}\" is not a count the file can hold", name,
                      abbreviate_line(e.name), i, abbreviate_line(token));
        t += std::min<uint64_t>(items, tokens.size() - t);
      }
    }
  }
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
    std::vector<bool> lists;  // per property: a list (a count, then that many items)
    bool known = false;       // a name Assimp reads entries of (check_ply_ascii_lists)
  };
  std::vector<Element> elements;
  bool ascii = false;
  const auto malformed = [&](const std::string& l) {
    return Error("{}: malformed PLY header line \"{}\"", name, abbreviate_line(l));
  };
  for (int lines = 0; lines < 10000 && std::getline(f, line); ++lines) {
    const bool crlf = !line.empty() && line.back() == '\r';
    if (crlf) line.pop_back();
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
      if (ascii) check_ply_ascii_lists(name, f, elements, remaining, crlf);
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
      // Assimp 5.2 reads the count of an element whose name it does not know (vertex, face,
      // tristrips, edge, material, TextureFile) from where the name starts, so a name that
      // starts with digits is a count of its own (fuzz_mesh: a name
      // "6666...vertex" made it reserve 64 GB).
      if (std::isdigit(static_cast<unsigned char>(w[1][0])))
        throw Error("{}: PLY element name \"{}\" starts with a digit (Assimp would read it as the count)", name,
                    abbreviate_line(w[1]));
      const bool known = w[1] == "vertex" || w[1] == "face" || w[1] == "tristrips" || w[1] == "edge" || w[1] == "material";
      elements.push_back({std::string(w[1]), count, 0, 0, {}, known});
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
      e.lists.push_back(list);
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

// One vertex of an OBJ face, line or point element: v, v/vt, v//vn or v/vt/vn, each an
// integer (negative: relative to the end).
bool obj_vertex_reference(std::string_view word) {
  int parts = 0;
  size_t i = 0;
  while (true) {
    const size_t start = i;
    if (i < word.size() && word[i] == '-') ++i;
    const size_t digits = i;
    while (i < word.size() && word[i] >= '0' && word[i] <= '9') ++i;
    const bool number = i > digits;
    // Only the texture coordinate (the second part) may be empty, as in v//vn.
    if (!number && !(parts == 1 && i == start && i < word.size())) return false;
    ++parts;
    if (i == word.size()) return true;
    if (word[i] != '/' || parts == 3) return false;
    ++i;
    if (i == word.size()) return false;
  }
}

// OBJ: Assimp 5.2's face parser reads past the end of its line buffer on a malformed vertex
// reference such as "1//1/1/23" or "/" (found by fuzz/mesh_fuzzer). Assimp reads a file as
// OBJ by its extension or, whatever it is called, when its first bytes hold OBJ keywords; so
// every text file is checked: each line starting with "f", "l" or "p" must list only well-formed
// references ("\\" continues the line; Assimp takes no comment after them either).
void check_obj_elements(const fs::path& path, std::ifstream& f) {
  std::string line;
  for (uint64_t n = 1; std::getline(f, line); ++n) {
    // Assimp takes the line's first character for the keyword ("f//1" is a face "//1"), so
    // the references start right after it.
    const size_t first = line.find_first_not_of(" \t");
    if (first == std::string::npos || (line[first] != 'f' && line[first] != 'l' && line[first] != 'p')) continue;
    const std::vector<std::string_view> words = split_words(std::string_view(line).substr(first + 1));
    for (size_t w = 0; w < words.size(); ++w) {
      std::string_view word = words[w];
      if (!word.empty() && word.back() == '\r') word.remove_suffix(1);
      if (word.empty() || word == "\\") continue;
      if (!obj_vertex_reference(word))
        throw Error("{}: line {}: '{}' is not a vertex reference (v, v/vt, v//vn or v/vt/vn)", path.string(), n,
                    abbreviate_line(word));
    }
  }
}

// glTF: Assimp 5.2 copies an accessor's bytes without checking that they lie inside its
// buffer view (found by fuzz/mesh_fuzzer: an accessor at byteOffset 5 reading 36 bytes of
// a 36-byte view). Every accessor (and sparse accessor part) must lie inside its view, every
// view inside its buffer, and every buffer must hold the bytes it declares (a data: URI's
// decoded size, the file it names, or a GLB's binary chunk).
class GltfBounds {
 public:
  GltfBounds(const fs::path& path, const nlohmann::json& doc, uint64_t glb_bin_size)
      : path_(path), doc_(doc), glb_bin_size_(glb_bin_size) {}

  void check() {
    const nlohmann::json& buffers = array("buffers");
    for (size_t i = 0; i < buffers.size(); ++i) {
      const uint64_t declared = number(buffers[i], "byteLength", fmt::format("buffers[{}]", i), true);
      const uint64_t held = buffer_size(buffers[i]);
      if (held != kUnknown && held < declared)
        fail("buffers[{}] declares {} bytes but holds {}", i, declared, held);
      buffer_lengths_.push_back(declared);
    }
    const nlohmann::json& views = array("bufferViews");
    for (size_t i = 0; i < views.size(); ++i) {
      const std::string at = fmt::format("bufferViews[{}]", i);
      const uint64_t b = index(views[i], "buffer", at, buffer_lengths_.size());
      const uint64_t offset = number(views[i], "byteOffset", at, false), length = number(views[i], "byteLength", at, true);
      if (offset + length > buffer_lengths_[b])
        fail("{} spans bytes {}..{} of buffers[{}], which holds {}", at, offset, offset + length, b, buffer_lengths_[b]);
      view_lengths_.push_back(length);
      view_strides_.push_back(number(views[i], "byteStride", at, false));
    }
    const nlohmann::json& accessors = array("accessors");
    for (size_t i = 0; i < accessors.size(); ++i) {
      const std::string at = fmt::format("accessors[{}]", i);
      const nlohmann::json& a = accessors[i];
      if (!a.is_object()) continue;  // Assimp reports it
      const uint64_t count = number(a, "count", at, true);
      const uint64_t element = component_size(a, at) * components(a, at);
      if (a.contains("bufferView")) span(a, at, count, element);
      if (a.contains("sparse") && a["sparse"].is_object()) {
        const nlohmann::json& sparse = a["sparse"];
        const uint64_t n = number(sparse, "count", at + ".sparse", true);
        if (sparse.contains("indices") && sparse["indices"].is_object())
          span(sparse["indices"], at + ".sparse.indices", n, component_size(sparse["indices"], at + ".sparse.indices"));
        if (sparse.contains("values") && sparse["values"].is_object()) span(sparse["values"], at + ".sparse.values", n, element);
      }
    }
  }

 private:
  static constexpr uint64_t kUnknown = std::numeric_limits<uint64_t>::max();
  static constexpr uint64_t kLimit = uint64_t(1) << 40;  // no glTF buffer of a mesh is a terabyte

  template <typename... Args>
  [[noreturn]] void fail(fmt::format_string<Args...> f, Args&&... args) const {
    throw Error("{}: {}", path_.string(), fmt::format(f, std::forward<Args>(args)...));
  }
  const nlohmann::json& array(const char* key) const {
    static const nlohmann::json empty = nlohmann::json::array();
    return doc_.contains(key) && doc_[key].is_array() ? doc_[key] : empty;
  }
  // A non-negative integer member (0 when absent and not required), at most kLimit.
  uint64_t number(const nlohmann::json& o, const char* key, const std::string& at, bool required) const {
    if (!o.is_object() || !o.contains(key)) {
      if (required) fail("{}.{}: required", at, key);
      return 0;
    }
    const nlohmann::json& v = o[key];
    if (!v.is_number_integer() || (!v.is_number_unsigned() && v.get<int64_t>() < 0) || v.get<uint64_t>() > kLimit)
      fail("{}.{}: expected a non-negative integer of at most 2^40, got {}", at, key, v.dump().substr(0, 40));
    return v.get<uint64_t>();
  }
  uint64_t index(const nlohmann::json& o, const char* key, const std::string& at, size_t size) const {
    const uint64_t i = number(o, key, at, true);
    if (i >= size) fail("{}.{}: {} is not an index of the {} there are", at, key, i, size);
    return i;
  }
  uint64_t component_size(const nlohmann::json& o, const std::string& at) const {
    switch (number(o, "componentType", at, true)) {
      case 5120: case 5121: return 1;
      case 5122: case 5123: return 2;
      case 5125: case 5126: return 4;
      default: fail("{}.componentType: not a glTF component type", at);
    }
  }
  uint64_t components(const nlohmann::json& a, const std::string& at) const {
    const std::string type = a.contains("type") && a["type"].is_string() ? a["type"].get<std::string>() : "";
    if (type == "SCALAR") return 1;
    if (type == "VEC2") return 2;
    if (type == "VEC3") return 3;
    if (type == "VEC4" || type == "MAT2") return 4;
    if (type == "MAT3") return 9;
    if (type == "MAT4") return 16;
    fail("{}.type: not a glTF accessor type", at);
  }
  // `count` elements of `element` bytes from o.bufferView at o.byteOffset, at the view's stride.
  void span(const nlohmann::json& o, const std::string& at, uint64_t count, uint64_t element) const {
    const uint64_t v = index(o, "bufferView", at, view_lengths_.size());
    const uint64_t offset = number(o, "byteOffset", at, false);
    const uint64_t stride = view_strides_[v] ? view_strides_[v] : element;
    // (Each term is at most 2^40; the product is checked before it is formed.)
    const bool too_many = count > kLimit / std::max<uint64_t>(stride, 1);
    if (too_many || (count == 0 ? offset : offset + (count - 1) * stride + element) > view_lengths_[v])
      fail("{} reads {} elements of {} bytes from byte {} of bufferViews[{}], which holds {}", at, count, element,
           offset, v, view_lengths_[v]);
  }
  // The bytes a buffer holds, or kUnknown when that cannot be told here (Assimp reports).
  uint64_t buffer_size(const nlohmann::json& b) const {
    if (!b.is_object() || !b.contains("uri")) return glb_bin_size_;
    if (!b["uri"].is_string()) return kUnknown;
    const std::string uri = b["uri"].get<std::string>();
    if (uri.rfind("data:", 0) == 0) {
      const size_t comma = uri.find(',');
      if (comma == std::string::npos || uri.find(";base64", 0) > comma) return kUnknown;
      const uint64_t chars = uri.size() - comma - 1;
      uint64_t padding = 0;
      for (size_t i = uri.size(); i > comma + 1 && uri[i - 1] == '=' && padding < 2; --i) ++padding;
      return (chars - padding) * 3 / 4;  // base64: 4 characters for 3 bytes
    }
    std::error_code ec;
    const uint64_t size = fs::file_size(path_.parent_path() / uri, ec);
    return ec ? kUnknown : size;
  }

  const fs::path& path_;
  const nlohmann::json& doc_;
  uint64_t glb_bin_size_;
  std::vector<uint64_t> buffer_lengths_, view_lengths_, view_strides_;
};

void check_gltf(const fs::path& path, std::ifstream& f, bool binary) {
  std::string json_text;
  uint64_t bin_size = std::numeric_limits<uint64_t>::max();  // no GLB: buffers without a uri are unknown
  if (binary) {
    // GLB: a 12-byte header, then chunks of (length, type, data): JSON first, BIN next.
    unsigned char header[20];
    if (!f.read(reinterpret_cast<char*>(header), 20)) return;
    auto u32 = [](const unsigned char* p) { return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24; };
    if (std::memcmp(header, "glTF", 4) != 0) return;
    const uint32_t json_length = u32(header + 12);
    if (json_length > (64u << 20)) return;  // Assimp reports what it cannot read
    json_text.resize(json_length);
    if (!f.read(json_text.data(), json_length)) return;
    unsigned char chunk[8];
    bin_size = f.read(reinterpret_cast<char*>(chunk), 8) ? u32(chunk) : 0;
  } else {
    json_text.assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
  }
  // Text that starts like a JSON object must be JSON. Assimp's parser (rapidjson) accepts
  // text nlohmann refuses, ill-formed UTF-8 in a key above all, and then reads the accessors
  // of a document these checks never saw (fuzz_mesh, 2026-11-28: a key "sc\xe5ne" and an
  // accessor reading past its view). Anything else is not glTF: Assimp's glTF reader
  // refuses it (and check_obj_elements below still checks it as OBJ text).
  const size_t bom = json_text.rfind("\xEF\xBB\xBF", 0) == 0 ? 3 : 0;
  const size_t first = json_text.find_first_not_of(" \t\r\n", bom);
  if (first == std::string::npos || json_text[first] != '{') return;
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(json_text);
  } catch (const nlohmann::json::exception& e) {
    // what(): "[json.exception.parse_error.101] parse error at line 1, column 95: ...; last
    // read: '...'": from "line", one line of printable ASCII (the bytes read may be anything).
    std::string msg = e.what();
    const size_t at = msg.find("at line ");
    if (at != std::string::npos) msg = msg.substr(at + 3);
    for (char& c : msg)
      if (c < 32 || c >= 127) c = '?';
    throw Error("{}: invalid glTF JSON: {}", path.string(), msg);
  }
  if (!doc.is_object()) return;
  GltfBounds(path, doc, bin_size).check();
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
  if (ext == ".glb" || std::string(magic, 3) == "glT") return check_gltf(path, f, /*binary=*/true);
  if (ext == ".gltf") check_gltf(path, f, /*binary=*/false);
  f.clear();
  f.seekg(0);
  check_obj_elements(path, f);
}

}  // namespace penumbra
