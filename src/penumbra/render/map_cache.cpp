#include "penumbra/render/map_cache.h"

#include <cstdio>
#include <sstream>
#include <system_error>

#include <fmt/format.h>

#include "penumbra/core/binary_io.h"
#include "penumbra/core/error.h"
#include "penumbra/core/file_util.h"
#include "penumbra/core/hash.h"
#include "penumbra/core/program_identity.h"
#include "penumbra/core/timer.h"

namespace penumbra {

namespace fs = std::filesystem;

namespace {

// 1: the first layout (header: magic, format, key, record bytes, record digest).
constexpr uint32_t kEntryFormat = 1;
constexpr uint64_t kEntryMagic = 0x3150414d424e50ull;  // "PNBMAP1"
constexpr const char* kEntryExtension = ".map";

template <class T>
void add_array(Digest128& d, const std::vector<T>& v) {
  d.add_value<uint64_t>(v.size());
  d.add(v.data(), v.size() * sizeof(T));
}

}  // namespace

MapCache::MapCache(fs::path dir) : dir_(std::move(dir)) {
  if (dir_.empty()) throw Error("--map-cache: an empty folder name");
  std::error_code ec;
  if (fs::exists(dir_, ec) && !fs::is_directory(dir_, ec))
    throw Error("--map-cache {}: exists and is not a folder", dir_.string());
  fs::create_directories(dir_, ec);
  if (ec) throw Error("--map-cache {}: cannot create the folder ({})", dir_.string(), ec.message());
}

std::string MapCache::geometry_digest(const Scene& scene) {
  Digest128 d;
  d.add_value<uint64_t>(scene.objects.size());
  for (const SceneObject& o : scene.objects) {
    add_array(d, o.mesh.positions);
    add_array(d, o.mesh.normals);
    add_array(d, o.mesh.indices);
    add_array(d, o.mesh.triangle_opacity);
    d.add_value(o.material.albedo);
    d.add_value(o.material.opacity);
    d.add_value<uint8_t>(o.material.two_sided);
    // Texture coordinates and the alpha texture's texels decide where a mask lets light through.
    add_array(d, o.mesh.uvs);
    d.add_value<uint8_t>(static_cast<uint8_t>(o.material.alpha.mode));
    d.add_value(o.material.alpha.cutoff);
    d.add_value<uint8_t>(o.material.alpha.texture != nullptr);
    if (o.material.alpha.texture) {
      d.add_value(o.material.alpha.texture->width());
      d.add_value(o.material.alpha.texture->height());
      d.add_value<uint8_t>(o.material.alpha.texture->has_alpha());
      add_array(d, o.material.alpha.texture->rgba());
    }
    d.add_value<uint8_t>(o.closed);
    d.add_value<uint8_t>(o.sphere.has_value());
    if (o.sphere) {
      d.add_value(o.sphere->center);
      d.add_value(o.sphere->radius);
    }
  }
  return d.hex();
}

std::string MapCache::key(const std::string& geometry_digest, const std::string& method,
                          const nlohmann::json& resolved_params, const ShadowContext& ctx) {
  Digest128 d;
  d.add_value(kEntryFormat);
  // nlohmann::json keeps object keys sorted: dump() is canonical.
  d.add(program_identity().dump());
  d.add(method);
  d.add(resolved_params.dump());
  d.add(geometry_digest);
  const AreaLight& l = *ctx.light;
  d.add_value(static_cast<int>(l.shape));
  d.add_value(l.center);
  d.add_value(l.frame.s);
  d.add_value(l.frame.t);
  d.add_value(l.frame.n);
  d.add_value(l.size);
  d.add_value(l.radius);
  d.add_value(l.radii);
  d.add_value(l.radiance);
  // A textured light's samples follow its image (one channel's table).
  d.add_value(l.texture_channel);
  d.add_value<uint8_t>(l.texture != nullptr);
  if (l.texture) {
    d.add_value(l.texture->image->width());
    d.add_value(l.texture->image->height());
    add_array(d, l.texture->image->rgba());
  }
  d.add_value(ctx.light_index);
  d.add_value(ctx.seed);
  d.add_value(ctx.light_samples);
  return d.hex();
}

fs::path MapCache::entry_path(const std::string& key, const std::string& method_name) const {
  return dir_ / fmt::format("{}-{}{}", method_name, key, kEntryExtension);
}

bool MapCache::load(const std::string& key, const std::string& method_name, ShadowMethod& method,
                    const ShadowContext& ctx) {
  Timer timer;
  const fs::path path = entry_path(key, method_name);
  bool hit = false;
  std::error_code ec;
  if (fs::exists(path, ec)) {
    try {
      const std::string bytes = read_text_file(path);
      std::istringstream in(bytes);
      uint64_t magic = 0, record_bytes = 0;
      uint32_t format = 0;
      std::vector<char> stored_key, digest;
      if (binary::read(in, magic) && magic == kEntryMagic && binary::read(in, format) && format == kEntryFormat &&
          binary::read_array(in, stored_key, 64) && std::string(stored_key.begin(), stored_key.end()) == key &&
          binary::read_array(in, digest, 64) && binary::read(in, record_bytes)) {
        const size_t start = static_cast<size_t>(in.tellg());
        if (start + record_bytes == bytes.size()) {
          Digest128 check;
          check.add(bytes.data() + start, record_bytes);
          if (check.hex() == std::string(digest.begin(), digest.end())) {
            std::istringstream record(bytes.substr(start));
            hit = method.load_prepared(record, ctx);
            if (hit) stats_.bytes_read += bytes.size();
          }
        }
      }
    } catch (const Error&) {
      hit = false;  // unreadable: prepared afresh and written again
    }
  }
  (hit ? stats_.hits : stats_.misses)++;
  stats_.load_ms += timer.elapsed_ms();
  return hit;
}

void MapCache::store(const std::string& key, const std::string& method_name, const ShadowMethod& method) {
  Timer timer;
  std::ostringstream record;
  method.save_prepared(record);
  const std::string body = record.str();
  Digest128 digest;
  digest.add(body.data(), body.size());
  const std::string digest_hex = digest.hex();
  std::ostringstream entry;
  binary::write(entry, kEntryMagic);
  binary::write(entry, kEntryFormat);
  binary::write_array(entry, std::vector<char>(key.begin(), key.end()));
  binary::write_array(entry, std::vector<char>(digest_hex.begin(), digest_hex.end()));
  binary::write<uint64_t>(entry, body.size());
  entry << body;
  const std::string bytes = entry.str();
  try {
    write_text_file_atomic(entry_path(key, method_name), bytes);
    stats_.stored++;
    stats_.bytes_written += bytes.size();
  } catch (const Error& e) {
    if (!warned_) std::fprintf(stderr, "warning: the map cache is not written: %s\n", e.what());
    warned_ = true;
  }
  stats_.store_ms += timer.elapsed_ms();
}

uint64_t MapCache::entry_bytes(int* entries) const {
  uint64_t bytes = 0;
  int count = 0;
  std::error_code ec;
  for (fs::directory_iterator it(dir_, ec), end; !ec && it != end; it.increment(ec)) {
    if (it->path().extension() != kEntryExtension) continue;
    std::error_code size_ec;
    const uint64_t size = fs::file_size(it->path(), size_ec);
    if (size_ec) continue;
    bytes += size;
    ++count;
  }
  if (entries) *entries = count;
  return bytes;
}

nlohmann::json MapCache::stats_json() const {
  int entries = 0;
  const uint64_t bytes = entry_bytes(&entries);
  return {{"dir", dir_.string()},
          {"hits", stats_.hits},
          {"misses", stats_.misses},
          {"hit_rate", stats_.hit_rate()},
          {"stored", stats_.stored},
          {"bytes_read", stats_.bytes_read},
          {"bytes_written", stats_.bytes_written},
          {"load_ms", stats_.load_ms},
          {"store_ms", stats_.store_ms},
          {"entries", entries},
          {"entry_bytes", bytes}};
}

}  // namespace penumbra
