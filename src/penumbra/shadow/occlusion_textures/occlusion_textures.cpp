#include "penumbra/shadow/occlusion_textures/occlusion_textures.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <limits>

#include <tbb/enumerable_thread_specific.h>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/gpu/raster/raster_layout_shared.h"
#include "penumbra/shadow/light_horizon.h"

namespace penumbra::occlusion {

Prefilter parse_prefilter(const std::string& s) {
  if (s == "mipmap") return Prefilter::Mipmap;
  if (s == "nbuffer") return Prefilter::NBuffer;
  if (s == "sat") return Prefilter::Sat;
  throw Error("occlusion-textures: prefilter '{}' must be mipmap, nbuffer or sat", s);
}
SatPrecision parse_sat_precision(const std::string& s) {
  if (s == "uint32") return SatPrecision::UInt32;
  if (s == "double") return SatPrecision::Double;
  throw Error("occlusion-textures: sat_precision '{}' must be uint32 or double", s);
}
Combine parse_combine(const std::string& s) {
  if (s == "product") return Combine::Product;
  if (s == "sum") return Combine::Sum;
  if (s == "max") return Combine::Max;
  throw Error("occlusion-textures: combine '{}' must be product, sum or max", s);
}
const char* to_string(Prefilter p) {
  switch (p) {
    case Prefilter::Mipmap: return "mipmap";
    case Prefilter::NBuffer: return "nbuffer";
    case Prefilter::Sat: return "sat";
  }
  return "?";
}
const char* to_string(Combine c) {
  switch (c) {
    case Combine::Product: return "product";
    case Combine::Sum: return "sum";
    case Combine::Max: return "max";
  }
  return "?";
}

Options options_from(const ParamSet& p) {
  Options o;
  o.slices = p.get_int("slices");
  o.resolution = p.get_int("resolution");
  o.prefilter = parse_prefilter(p.get_string("prefilter"));
  o.sat_precision = parse_sat_precision(p.get_string("sat_precision"));
  o.combine = parse_combine(p.get_string("combine"));
  o.horizon = p.get_bool("horizon");
  o.own_slice = p.get_bool("own_slice");
  o.own_slice_scale = p.get_int("own_slice_scale");
  o.thin_fix = p.get_bool("thin_fix");
  o.fade = p.get_float("fade");
  o.open_fade = p.get_float("open_fade");
  o.cop_distance = p.get_float("cop_distance");
  o.cull_planar = p.get_bool("cull_planar");
  o.cull_back_faces = p.get_bool("cull_back_faces");
  o.tiles = p.get_int("tiles");
  o.near_field = p.get_float("near_field");
  return o;
}

LightRect light_rect(const AreaLight& light) {
  LightRect r;
  r.center = light.center;
  r.right = light.frame.s;
  r.up = light.frame.t;
  r.forward = light.frame.n;
  if (light.shape == LightShape::Rect) {
    r.width = light.size.x;
    r.height = light.size.y;
  } else if (light.shape == LightShape::Ellipsoid) {  // the bounding rect of its central ellipse
    r.width = 2 * light.radii.x;
    r.height = 2 * light.radii.y;
  } else {  // a disk, or a sphere's disk facing frame.n: the bounding square
    r.width = r.height = 2 * light.radius;
  }
  return r;
}

namespace {

// Whether object `i` is planar and cannot shadow anything: the whole light lies strictly on
// one side of its plane and no vertex of any other object lies on the other side by more than
// a thousandth of the scene's size. A segment from a point to the light then crosses the plane
// only at that point if it lies on the plane, and never otherwise (a ground plane under the
// light, a wall behind it). The thousandth: objects sunk a hair into the ground are how scenes
// are written (a trunk or a wall set into the terrain, a box whose size and position were
// rounded: scenes/street.json's buildings reach 5 mm below its ground), and what the ground would
// shadow there is inside them.
bool is_planar_non_caster(const Scene& scene, size_t i, const LightRect& light) {
  const TriangleMesh& m = scene.objects[i].mesh;
  if (m.triangle_count() == 0) return true;
  // The plane of the first triangle that is not a sliver; every vertex must lie on it (a
  // non-planar mesh fails at its first vertex off the plane).
  const Bounds3f b = m.bounds();
  const float extent = length(b.diagonal());
  Vec3f normal;
  for (size_t t = 0; t < m.triangle_count() && !(length_squared(normal) > 0); ++t) {
    const Vec3f c = cross(m.vertex(t, 1) - m.vertex(t, 0), m.vertex(t, 2) - m.vertex(t, 0));
    if (length(c) > 1e-3f * extent * extent) normal = normalize(c);
  }
  if (!(length_squared(normal) > 0)) return false;
  const float offset = dot(normal, m.vertex(0, 0));
  const float tol = 1e-5f * (extent + max_component(vmax(vmax(b.hi, -b.lo), Vec3f(0.0f))));
  for (Vec3f p : m.positions)
    if (std::abs(dot(normal, p) - offset) > tol) return false;
  // The light's corners: all strictly on one side.
  int side = 0;
  for (int c = 0; c < 4; ++c) {
    Vec3f corner = light.center + light.right * (((c & 1) ? 0.5f : -0.5f) * light.width) +
                   light.up * (((c & 2) ? 0.5f : -0.5f) * light.height);
    float s = dot(normal, corner) - offset;
    int cs = s > tol ? 1 : (s < -tol ? -1 : 0);
    if (cs == 0 || (side != 0 && cs != side)) return false;
    side = cs;
  }
  const float sink = std::max(tol, 1e-3f * length(scene.bounds().diagonal()));
  for (size_t j = 0; j < scene.objects.size(); ++j) {
    if (j == i) continue;
    for (Vec3f p : scene.objects[j].mesh.positions)
      if (side * (dot(normal, p) - offset) < -sink) return false;
  }
  return true;
}

}  // namespace

OcclusionTextures::OcclusionTextures(const Options& options) : options_(options) {
  if (options.slices < 1 || options.slices > 32)
    throw Error("occlusion-textures: slices = {} must be in [1, 32]", options.slices);
  if (options.resolution < 16 || options.resolution > 4096 || !std::has_single_bit(static_cast<unsigned>(options.resolution)))
    throw Error("occlusion-textures: resolution = {} must be a power of two in [16, 4096]", options.resolution);
  if (!(options.fade >= 0)) throw Error("occlusion-textures: fade = {} must be >= 0", options.fade);
  if (!(options.open_fade >= 0)) throw Error("occlusion-textures: open_fade = {} must be >= 0", options.open_fade);
  if (options.own_slice_scale != 0 && options.own_slice_scale != 1 && options.own_slice_scale != 2 &&
      options.own_slice_scale != 4)
    throw Error("occlusion-textures: own_slice_scale = {} must be 0 (fitted), 1, 2 or 4", options.own_slice_scale);
  if (options.resolution * options.own_slice_scale > 8192)
    throw Error("occlusion-textures: own_slice_scale = {} makes the own slice's depths {} texels a side, more than 8192 "
                "(resolution {})", options.own_slice_scale, options.resolution * options.own_slice_scale,
                options.resolution);
  if (!(options.cop_distance >= 0)) throw Error("occlusion-textures: cop_distance = {} must be >= 0", options.cop_distance);
  if (options.tiles != 0 && (options.tiles > 64 || !std::has_single_bit(static_cast<unsigned>(options.tiles)) ||
                             options.resolution / options.tiles < 8))
    throw Error("occlusion-textures: tiles = {} must be 0 (fitted) or a power of two in [1, 64], with tiles of at least "
                "8 texels (resolution {})", options.tiles, options.resolution);
}

int own_slice_fitted_scale(const Options& o, uint64_t caster_triangles) {
  if (o.own_slice_scale != 0) return o.own_slice_scale;
  const uint64_t texels = static_cast<uint64_t>(o.resolution) * static_cast<uint64_t>(o.resolution);
  return caster_triangles > texels && o.resolution * 2 <= 8192 ? 2 : 1;
}

int own_slice_side(const Options& o, uint64_t caster_triangles) {
  return o.own_slice ? o.resolution * own_slice_fitted_scale(o, caster_triangles) : 0;
}

void OcclusionTextures::plan(const Scene& scene, const AreaLight& light) {
  light_ = light_rect(light);
  const int S = options_.slices, R = options_.resolution;

  // Casters: every object but the planar ones that cannot shadow anything.
  culled_.clear();
  for (size_t i = 0; i < scene.objects.size(); ++i)
    if (options_.cull_planar && is_planar_non_caster(scene, i, light_)) culled_.push_back(static_cast<uint32_t>(i));

  // The casters' depth range, and the largest d for which the frustum from E = C - d forward
  // through the light's edges contains every caster vertex in front of the light: a vertex at
  // depth z and lateral offset |u| > w/2 needs (w/2)(z + d)/d >= |u|, d <= z / (2|u|/w - 1).
  const float hw = 0.5f * light_.width, hh = 0.5f * light_.height;
  const float z_eps = 1e-5f * std::max(light_.width, light_.height);
  float zmin = kInfinity, zmax = -kInfinity, d_fit = kInfinity;
  bool open_casters = false;
  uint64_t caster_triangles = 0;
  for (size_t i = 0, c = 0; i < scene.objects.size(); ++i) {
    if (c < culled_.size() && culled_[c] == i) {
      ++c;
      continue;
    }
    open_casters = open_casters || !scene.objects[i].closed;
    caster_triangles += scene.objects[i].mesh.triangle_count();
    for (Vec3f p : scene.objects[i].mesh.positions) {
      const Vec3f q = p - light_.center;
      const float z = dot(q, light_.forward);
      if (!(z > z_eps)) continue;
      zmin = std::min(zmin, z);
      zmax = std::max(zmax, z);
      const float au = std::abs(dot(q, light_.right)), av = std::abs(dot(q, light_.up));
      if (au > hw) d_fit = std::min(d_fit, z / (au / hw - 1));
      if (av > hh) d_fit = std::min(d_fit, z / (av / hh - 1));
    }
  }
  has_casters_ = zmax > 0;
  // The own slice's test is for canopies, open surfaces shadowing each other from centimetres
  // away: a scene whose casters are all closed keeps the paper's slices (the fade serves a solid's
  // own faces), and the nearest depths are not kept.
  own_slice_active_ = options_.own_slice && open_casters;
  own_slice_scale_ = own_slice_fitted_scale(options_, caster_triangles);
  setup_ = {};
  setup_.center = light_.center;
  setup_.forward = light_.forward;
  setup_.slices = S;
  setup_.combine = options_.combine == Combine::Sum ? shader::kOtSum
                   : options_.combine == Combine::Max ? shader::kOtMax
                                                      : shader::kOtProduct;
  setup_.horizon = options_.horizon ? 1u : 0u;
  setup_.light = horizon_light(light);
  setup_.near_field = options_.near_field;
  setup_.light_width = shader::near_field_light_width(light.area());
  setup_.tiles = 1;
  tiles_side_ = 1;
  tiles_.assign(1, shader::OtTile{0.0f, 1.0f});
  if (!has_casters_) return;
  bottom_ = zmax;
  top_ = std::max(z_eps, std::min(zmin, bottom_ * (1 - 1e-3f)));
  thickness_ = (bottom_ - top_) / float(S);
  const float d_min = 0.02f * std::max(light_.width, light_.height), d_max = std::max(2 * bottom_, d_min);
  d_ = options_.cop_distance > 0 ? options_.cop_distance : std::clamp(d_fit * (1 - 1e-3f), d_min, d_max);
  // One perspective pass from E, the window at depth d being the light itself.
  const Vec3f eye = light_.center - light_.forward * d_;
  const float near = (d_ + top_) * (1 - 1e-5f), far = (d_ + bottom_) * (1 + 1e-5f);
  const float sx = hw * near / d_, sy = hh * near / d_;
  view_ = LightView::frustum(eye, light_.forward, light_.up, -sx, sx, -sy, sy, near, far, R, R);
  const int RN = R * own_slice_scale_;
  nearest_view_ = LightView::frustum(eye, light_.forward, light_.up, -sx, sx, -sy, sy, near, far, RN, RN);
  // The per-point arithmetic's record (occlusion_shared.h).
  setup_.has_casters = 1u;
  setup_.right = view_.right();
  setup_.up = view_.up();
  setup_.R = float(R);
  setup_.kx = setup_.R / light_.width;
  setup_.ky = setup_.R / light_.height;
  setup_.d = d_;
  setup_.fade = options_.fade > 0 ? 1u : 0u;
  setup_.fade_length = options_.fade;
  setup_.open_fade_length = options_.open_fade;
  // The light-space tiles: given, or fitted so that the largest kernel (a receiver at the casters'
  // farthest depth, the slice plane at their nearest: eq. 4) spans at most four tiles a side, which
  // bounds the lookups a point makes (ot_visibility_tiled), with tiles of at least 8 texels. Fitted
  // tiles are kept only where they make the slices at least three times thinner on average (a
  // wide scene of separate casters, as a forest's crowns); one compact object's tiles see most of
  // its depth, and their pieces' approximations and lookups would cost more than they gain
  // (docs/methods/occlusion-textures.md, "Slices that follow the casters"). A tile without
  // casters keeps the whole range's slices, and a point whose kernels reach only such tiles is
  // shaded as with one range (one lookup a slice, the CPU's batches). Where the own slice is
  // tested, fitted tiles are not made: they thinned the slices so that a leaf's near occluders
  // fell in a slice above it, which the own slice's depths now test directly; their thinner
  // slices would only count a crown more often in eq. 5's product (the ground under the 25-tree
  // forest: too dark by 0.034 with the tiles, by 0.006 without; docs/methods/occlusion-textures.md
  // "The own slice").
  const int T = options_.tiles != 0 ? options_.tiles : own_slice_active_ ? 1 : fitted_tiles();
  set_tiles(T);
  if (T > 1) fit_tiles(scene);
  if (options_.tiles == 0 && T > 1) {
    double ratio = 0;
    size_t used = 0;
    for (const shader::OtTile& t : tiles_)
      if (t.top != top_ || t.thickness != thickness_) ratio += t.thickness / thickness_, ++used;
    if (!(used > 0 && ratio <= used / 3.0)) set_tiles(1);
  }
}

int OcclusionTextures::fitted_tiles() const {
  const int R = options_.resolution;
  const float largest = (bottom_ - top_) / bottom_ * float(R) * d_ / (top_ + d_);
  const int side = static_cast<int>(std::bit_ceil(static_cast<unsigned>(std::clamp(largest / 4, 1.0f, float(R)))));
  return std::clamp(R / std::max(side, 8), 1, 64);
}

void OcclusionTextures::set_tiles(int T) {
  tiles_side_ = T;
  setup_.tiles = T;
  setup_.tile_side = float(options_.resolution / T);
  setup_.tile_scale = 1.0f / setup_.tile_side;
  setup_.top = top_;
  setup_.thickness = thickness_;
  tiles_.assign(size_t(T) * size_t(T), shader::OtTile{top_, thickness_});
}

// Each light-space tile's slices over the depth range of the casters it sees: every caster
// triangle's depth range joins the tiles its projected bounding box touches (a conservative
// range: the slicing rasterizer clamps a fragment outside its tile's range into the first or
// last slice). A tile without casters keeps the whole range (nothing is sliced there). A
// crown's leaves in a forest then shadow each other across slices a crown deep, not a forest
// deep (docs/methods/occlusion-textures.md, "Slices that follow the casters").
void OcclusionTextures::fit_tiles(const Scene& scene) {
  const int T = tiles_side_, S = options_.slices;
  const float R = setup_.R, scale = setup_.tile_scale, z_eps = 1e-5f * std::max(light_.width, light_.height);
  const Vec3f right = view_.right(), up = view_.up();
  struct Range {
    std::vector<float> lo, hi;
  };
  tbb::enumerable_thread_specific<Range> ranges([&] {
    return Range{std::vector<float>(tiles_.size(), kInfinity), std::vector<float>(tiles_.size(), -kInfinity)};
  });
  std::vector<uint32_t> casters;
  for (size_t i = 0, c = 0; i < scene.objects.size(); ++i) {
    if (c < culled_.size() && culled_[c] == i) {
      ++c;
      continue;
    }
    casters.push_back(static_cast<uint32_t>(i));
  }
  // Each vertex projected once (a vertex is shared by about six triangles): its texel position
  // and depth, x = NaN when it lies at or behind the light's plane.
  struct Projected {
    float x, y, z;
  };
  tbb::enumerable_thread_specific<std::vector<Projected>> projected;
  parallel_for(casters.size(), 1, [&](size_t b, size_t e) {
    Range& r = ranges.local();
    std::vector<Projected>& pv = projected.local();
    for (size_t c = b; c < e; ++c) {
      const TriangleMesh& m = scene.objects[casters[c]].mesh;
      pv.resize(m.positions.size());
      for (size_t i = 0; i < m.positions.size(); ++i) {
        const Vec3f q = m.positions[i] - light_.center;
        const float z = dot(q, light_.forward);
        const float a = d_ / (z + d_);
        pv[i] = z > z_eps ? Projected{0.5f * R + dot(q, right) * a * setup_.kx, 0.5f * R - dot(q, up) * a * setup_.ky, z}
                          : Projected{std::numeric_limits<float>::quiet_NaN(), 0.0f, z};
      }
      for (size_t t = 0; t < m.triangle_count(); ++t) {
        const Projected& p0 = pv[m.indices[3 * t]];
        const Projected& p1 = pv[m.indices[3 * t + 1]];
        const Projected& p2 = pv[m.indices[3 * t + 2]];
        float lo = std::min({p0.z, p1.z, p2.z}), hi = std::max({p0.z, p1.z, p2.z});
        if (!(hi > z_eps)) continue;  // wholly behind the light's plane: not sliced
        lo = std::clamp(lo, top_, bottom_), hi = std::clamp(hi, top_, bottom_);
        // A triangle cut by the light's plane projects without bound: every tile.
        int tx0 = 0, ty0 = 0, tx1 = T - 1, ty1 = T - 1;
        if (!std::isnan(p0.x) && !std::isnan(p1.x) && !std::isnan(p2.x)) {
          const float x0 = std::min({p0.x, p1.x, p2.x}), x1 = std::max({p0.x, p1.x, p2.x});
          const float y0 = std::min({p0.y, p1.y, p2.y}), y1 = std::max({p0.y, p1.y, p2.y});
          const float margin = 1e-3f;
          if (x1 < -margin || y1 < -margin || x0 > R + margin || y0 > R + margin) continue;  // outside the texture
          tx0 = std::clamp(int(std::floor((x0 - margin) * scale)), 0, T - 1);
          tx1 = std::clamp(int(std::floor((x1 + margin) * scale)), 0, T - 1);
          ty0 = std::clamp(int(std::floor((y0 - margin) * scale)), 0, T - 1);
          ty1 = std::clamp(int(std::floor((y1 + margin) * scale)), 0, T - 1);
        }
        for (int ty = ty0; ty <= ty1; ++ty)
          for (int tx = tx0; tx <= tx1; ++tx) {
            const size_t i = size_t(ty) * T + tx;
            r.lo[i] = std::min(r.lo[i], lo);
            r.hi[i] = std::max(r.hi[i], hi);
          }
      }
    }
  });
  std::vector<float> lo(tiles_.size(), kInfinity), hi(tiles_.size(), -kInfinity);
  for (const Range& r : ranges)
    for (size_t i = 0; i < tiles_.size(); ++i) lo[i] = std::min(lo[i], r.lo[i]), hi[i] = std::max(hi[i], r.hi[i]);
  // A tile's slices are at least a thousandth of the whole range's (a tile holding one flat caster
  // facing the light has no depth range of its own).
  const float min_thickness = 1e-3f * thickness_;
  for (size_t i = 0; i < tiles_.size(); ++i)
    if (hi[i] >= lo[i]) tiles_[i] = shader::OtTile{lo[i], std::max((hi[i] - lo[i]) / float(S), min_thickness)};
}

void OcclusionTextures::build(const Scene& scene, const AreaLight& light, MethodStats* stats) {
  Timer timer;
  const int S = options_.slices, R = options_.resolution;
  plan(scene, light);
  triangles_ = RasterTriangles{};
  masks_.width = masks_.height = 0;
  masks_.masks.clear();
  masks_.nearest.clear();
  nearest_.width = nearest_.height = 0;
  nearest_.masks.clear();
  nearest_.nearest.clear();
  if (!has_casters_) {
    stats->add_phase("slicing", timer.elapsed_ms());
    stats->add_phase("filtering", 0.0);
    return;
  }

  // The casters' triangles; of a closed object only those facing E (where rays from E enter
  // the solid) when cull_back_faces: the solid then occludes once in eq. 5, not twice.
  const Vec3f eye = view_.eye();
  for (size_t i = 0, c = 0; i < scene.objects.size(); ++i) {
    if (c < culled_.size() && culled_[c] == i) {
      ++c;
      continue;
    }
    const SceneObject& o = scene.objects[i];
    const size_t first = triangles_.size();
    append_raster_triangles(o.mesh, o.material, static_cast<uint32_t>(i), &triangles_);
    if (options_.cull_back_faces && o.closed) {
      auto facing_away = [&](const RasterTriangle& t) {
        return !(dot(cross(t.p[1] - t.p[0], t.p[2] - t.p[0]), eye - t.p[0]) > 0);
      };
      std::vector<RasterTriangle>& list = triangles_.list;
      list.erase(std::remove_if(list.begin() + first, list.end(), facing_away), list.end());
    }
  }

  std::vector<Vec2f> tile_bins;
  rasterizer_.depth_bin_masks(triangles_, view_, RasterFilter{}, slicing_bins(&tile_bins), &masks_);
  const size_t slicing_fragments = rasterizer_.stats().fragments;
  // The own slice's nearest depths at their finer texels (own_slice_scale > 1): a pass of their own.
  if (own_slice_active_ && own_slice_scale_ > 1)
    rasterizer_.depth_bin_masks(triangles_, nearest_view_, RasterFilter{}, nearest_bins(&tile_bins), &nearest_);
  if (options_.thin_fix && S > 1) {
    // Thin occluders (Fig. 6): what a slice holds is also written into the next slice
    // farther from the light, closing the gaps through surfaces cut by a slice plane.
    const uint32_t all = S == 32 ? ~0u : (1u << S) - 1;
    parallel_for(masks_.masks.size(), 65536, [&](size_t b, size_t e) {
      uint32_t* m = masks_.masks.data();
      for (size_t i = b; i < e; ++i) m[i] |= (m[i] << 1) & all;
    });
  }
  stats->add_phase("slicing", timer.elapsed_ms());

  timer.reset();
  const CoverageStack stack{R, R, S, masks_.masks};
  slice_bounds_.clear();
  if (tiles_side_ > 1) slice_bounds_ = coverage_bounds(stack);
  switch (options_.prefilter) {
    case Prefilter::Mipmap: mipmap_.build(stack); break;
    case Prefilter::NBuffer: nbuffer_.build(stack); break;
    case Prefilter::Sat:
      if (options_.sat_precision == SatPrecision::UInt32)
        sat32_.build(stack);
      else
        sat64_.build(stack);
      break;
  }
  stats->add_phase("filtering", timer.elapsed_ms());
  stats->memory_bytes = std::max<uint64_t>(stats->memory_bytes, texture_bytes());
  stats->extra["cop_distance"] = d_;
  stats->extra["tiles"] = tiles_side_;
  stats->extra["own_slice"] = own_slice_active_;
  if (own_slice_active_) stats->extra["own_slice_scale"] = own_slice_scale_;
  stats->extra["depth_range"] = {top_, bottom_};
  stats->extra["caster_triangles"] = triangles_.size();
  // Fragments of the slicing pass: they grow with the texels the casters cover, i.e. as the
  // light (to which the texture is fitted, §3.4) shrinks relative to the casters.
  stats->extra["slicing_fragments"] = slicing_fragments;
  nlohmann::json culled = nlohmann::json::array();
  for (uint32_t i : culled_) culled.push_back(scene.objects[i].name);
  stats->extra["culled_objects"] = culled;
}

DepthBins OcclusionTextures::slicing_bins(std::vector<Vec2f>* tile_storage) const {
  DepthBins bins{d_ + top_, thickness_, options_.slices};
  bins.nearest = own_slice_active_ && own_slice_scale_ == 1;  // each slice's nearest depths (ot_own_slice)
  tile_storage->clear();
  if (tiles_side_ > 1) {
    for (const shader::OtTile& t : tiles_) tile_storage->push_back(Vec2f(d_ + t.top, t.thickness));
    bins.tiles = *tile_storage;
    bins.tile_side = options_.resolution / tiles_side_;
  }
  return bins;
}

DepthBins OcclusionTextures::nearest_bins(std::vector<Vec2f>* tile_storage) const {
  DepthBins bins = slicing_bins(tile_storage);
  bins.nearest = true;
  bins.tile_side *= own_slice_scale_;
  return bins;
}

std::vector<uint32_t> OcclusionTextures::slicing_object_flags(const Scene& scene) const {
  std::vector<uint32_t> flags(scene.objects.size(), 0u);
  for (uint32_t i : culled_) flags[i] |= shader::kRasterObjectSkip;
  if (options_.cull_back_faces)
    for (size_t i = 0; i < scene.objects.size(); ++i)
      if (scene.objects[i].closed) flags[i] |= shader::kRasterObjectFrontOnly;
  return flags;
}

size_t OcclusionTextures::texture_bytes() const {
  size_t filter = 0;
  switch (options_.prefilter) {
    case Prefilter::Mipmap: filter = mipmap_.memory_bytes(); break;
    case Prefilter::NBuffer: filter = nbuffer_.memory_bytes(); break;
    case Prefilter::Sat:
      filter = options_.sat_precision == SatPrecision::UInt32 ? sat32_.memory_bytes() : sat64_.memory_bytes();
      break;
  }
  return filter + masks_.masks.size() * sizeof(uint32_t) + masks_.nearest.size() * sizeof(float) +
         nearest_.masks.size() * sizeof(uint32_t) + nearest_.nearest.size() * sizeof(float);
}

uint64_t OcclusionTextures::texture_bytes(const Options& o, uint64_t caster_triangles) {
  const int R = o.resolution, S = o.slices;
  uint64_t filter = 0;
  switch (o.prefilter) {
    case Prefilter::Mipmap: filter = MipmapFilter::bytes(R, R, S); break;
    case Prefilter::NBuffer: filter = NBufferFilter::bytes(R, R, S); break;
    case Prefilter::Sat:
      filter = o.sat_precision == SatPrecision::UInt32 ? SatFilter<uint32_t>::bytes(R, R, S)
                                                        : SatFilter<double>::bytes(R, R, S);
      break;
  }
  const int RN = own_slice_side(o, caster_triangles);  // a pass of its own above R
  const uint64_t own = DepthBinMasks::nearest_bytes(RN, RN, S) + (RN > R ? DepthBinMasks::bytes(RN, RN) : 0);
  return filter + DepthBinMasks::bytes(R, R) + own;
}

template <class Fn>
decltype(auto) OcclusionTextures::dispatch(Fn&& fn) const {
  switch (options_.prefilter) {
    case Prefilter::Mipmap: return fn(mipmap_);
    case Prefilter::NBuffer: return fn(nbuffer_);
    case Prefilter::Sat: break;
  }
  if (options_.sat_precision == SatPrecision::UInt32) return fn(sat32_);
  return fn(sat64_);
}

float OcclusionTextures::box(int k, float x0, float y0, float x1, float y1, LookupCounters* counters) const {
  LookupCounters local;
  LookupCounters& n = counters ? *counters : local;
  return dispatch([&](const auto& f) { return f.box(k, x0, y0, x1, y1, n); });
}


// A batch of points (the view samples of one image tile) in the light's frame, structure of
// arrays, sorted by how many slices lie between the point and the light, most first: slice k
// then shades the prefix of points with more than k slices above them.
struct OcclusionTextures::Batch {
  std::vector<Vec3f> points;      // as added
  std::vector<uint32_t> targets;  // where each point's V goes
  std::vector<float> horizon;     // as added: what the point's V is multiplied by (ot_horizon)
  std::vector<float> near_z;      // as added: the depth of its near field (ot_near_field_depth)
  std::vector<uint8_t> above;     // slices above each point
  std::vector<float> u, v, z, inv_z, near, product, sum, largest, cx, cy, side, occlusion;  // sorted
  std::vector<uint32_t> target;                                                    // sorted
  // One slice's kernels that meet the texture: their index among the points, centre and side.
  std::vector<uint32_t> meets;
  std::vector<float> meets_cx, meets_cy, meets_side;
  void reset(size_t n) {
    points.resize(n);
    targets.resize(n);
    horizon.resize(n);
    near_z.resize(n);
  }
};

namespace {

// The kernels of a slice (texture plane at depth zp) for m points: centre and side in texels
// (occlusion_shared.h ot_kernel).
PENUMBRA_OT_CLONES void kernels(size_t m, const float* __restrict u, const float* __restrict v, const float* __restrict z,
                                const float* __restrict inv_z, const shader::OtSetup& setup, float zp,
                                float* __restrict cx, float* __restrict cy, float* __restrict side) {
  for (size_t i = 0; i < m; ++i) {
    const shader::OtKernel kern = shader::ot_kernel(setup, zp, u[i], v[i], z[i], inv_z[i]);
    cx[i] = kern.cx;
    cy[i] = kern.cy;
    side[i] = kern.side;
  }
}

// Slice k's occlusion, faded in below its plane and left out over the point's near field, into
// the three combinations (occlusion_shared.h ot_accumulate).
inline void accumulate_one(const shader::OtSlicing& slicing, float z, float zp, float near_z, float occ,
                           float& product, float& sum, float& largest) {
  shader::OtCombined c{product, sum, largest};
  shader::ot_accumulate(c, slicing, z, zp, near_z, occ);
  product = c.product;
  sum = c.sum;
  largest = c.largest;
}
PENUMBRA_OT_CLONES void accumulate(size_t m, const float* __restrict z, const float* __restrict near_z,
                                   const float* __restrict occ, float zp, shader::OtSlicing slicing,
                                   float* __restrict product, float* __restrict sum, float* __restrict largest) {
  for (size_t i = 0; i < m; ++i)
    accumulate_one(slicing, z[i], zp, near_z[i], occ[i], product[i], sum[i], largest[i]);
}

// Whether a kernel meets the R x R texture (the same test as the filters' clipping; outside
// counts as empty, prefilter.h).
inline bool meets_texture(float cx, float cy, float side, float R) {
  const float half = 0.5f * std::max(side, 1.0f);
  const float x0 = cx - half, x1 = cx + half, y0 = cy - half, y1 = cy + half;
  return (std::min(x1, R) - std::max(x0, 0.0f) > 0) && (std::min(y1, R) - std::max(y0, 0.0f) > 0);
}

// How many of the m kernels meet the texture.
PENUMBRA_OT_CLONES size_t count_meeting_texture(size_t m, const float* __restrict cx, const float* __restrict cy,
                                                const float* __restrict side, float R) {
  size_t a = 0;
  for (size_t i = 0; i < m; ++i) a += meets_texture(cx[i], cy[i], side[i], R);
  return a;
}

// The kernels that meet the texture: their indices into meets[], their centres and sides
// gathered; returns how many.
PENUMBRA_OT_CLONES size_t kernels_meeting_texture(size_t m, const float* __restrict cx, const float* __restrict cy,
                                                  const float* __restrict side, float R, uint32_t* __restrict meets,
                                                  float* __restrict mx, float* __restrict my, float* __restrict ms) {
  size_t a = 0;
  for (size_t i = 0; i < m; ++i) {
    meets[a] = static_cast<uint32_t>(i);
    mx[a] = cx[i];
    my[a] = cy[i];
    ms[a] = side[i];
    a += meets_texture(cx[i], cy[i], side[i], R);
  }
  return a;
}

// accumulate() for the kernels meets[0..a) (occ[j] belongs to point meets[j]).
PENUMBRA_OT_CLONES void accumulate_at(size_t a, const uint32_t* __restrict meets, const float* __restrict z,
                                      const float* __restrict near_z, const float* __restrict occ, float zp,
                                      shader::OtSlicing slicing, float* __restrict product, float* __restrict sum,
                                      float* __restrict largest) {
  for (size_t j = 0; j < a; ++j) {
    const uint32_t i = meets[j];
    accumulate_one(slicing, z[i], zp, near_z[i], occ[j], product[i], sum[i], largest[i]);
  }
}

}  // namespace

// V for every point of the batch into out[target]. For slice k and a point P at depth z > zp
// (zp = plane(k)): the light seen from P cuts plane k in a square of t x size(light), t =
// (z - zp) / z (eq. 4), centred where P-C crosses the plane; in texels its side is
// t R d / (zp + d) and its centre is R/2 + u (zp / z) (d / (zp + d)) R / width (and likewise
// in y, rows downward). The slice just above P fades in over `fade` slice thicknesses (§3.4);
// the slice containing P and those below are not looked up. Kernels entirely outside the
// texture (points outside the slicing frustum, on the slices nearest to them) are 0 without a
// lookup: with a small light most of a wide receiver lies outside the frustum fitted to the
// light (§3.4), and filtering those zeros was what made small lights slower to shade.
template <class F>
void OcclusionTextures::shade_batch(const F& filter, Batch& b, bool open, std::span<float> out,
                                    LookupCounters& n) const {
  const size_t count = b.points.size();
  const int S = options_.slices;
  for (auto* a : {&b.u, &b.v, &b.z, &b.inv_z, &b.near, &b.product, &b.sum, &b.largest, &b.cx, &b.cy, &b.side,
                  &b.occlusion, &b.meets_cx, &b.meets_cy, &b.meets_side})
    a->resize(count);
  b.target.resize(count);
  b.meets.resize(count);
  b.above.resize(count);
  // The whole depth range's slices (the batch's points reach no tile with slices of its own).
  const shader::OtSlicing slicing = shader::ot_slicing(setup_, top_, thickness_, open);
  // Slices above each point, and a counting sort by that number, descending.
  uint32_t bucket[33] = {};
  const Vec3f right = view_.right(), up = view_.up();
  for (size_t i = 0; i < count; ++i) {
    const int a = shader::ot_slices_above(setup_, slicing, dot(b.points[i] - light_.center, light_.forward));
    b.above[i] = static_cast<uint8_t>(a);
    ++bucket[a];
  }
  uint32_t next[33];
  for (int a = S, start = 0; a >= 0; --a) {
    next[a] = static_cast<uint32_t>(start);
    start += static_cast<int>(bucket[a]);
  }
  for (size_t i = 0; i < count; ++i) {
    const uint32_t j = next[b.above[i]]++;
    const Vec3f q = b.points[i] - light_.center;
    b.u[j] = dot(q, right);
    b.v[j] = dot(q, up);
    b.z[j] = dot(q, light_.forward);
    b.inv_z[j] = 1.0f / b.z[j];
    b.near[j] = b.near_z[i];
    b.product[j] = 1.0f;
    b.sum[j] = b.largest[j] = 0.0f;
    b.target[j] = b.targets[i];
  }
  size_t m = count;
  for (int k = 0; k < S; ++k) {
    m -= bucket[k];  // the points with exactly k slices above drop out
    if (m == 0) break;
    const float zp = shader::ot_plane(slicing, k);
    kernels(m, b.u.data(), b.v.data(), b.z.data(), b.inv_z.data(), setup_, zp, b.cx.data(), b.cy.data(),
            b.side.data());
    // Kernels outside the texture are 0. When more than a quarter of them are, the others are
    // gathered and filtered alone; otherwise the filter's own clipping gives the zeros (a
    // gather and scatter would cost more than it saves).
    const size_t inside = count_meeting_texture(m, b.cx.data(), b.cy.data(), b.side.data(), setup_.R);
    if (4 * inside >= 3 * m) {
      filter.squares(k, m, b.cx.data(), b.cy.data(), b.side.data(), b.occlusion.data(), n);
      accumulate(m, b.z.data(), b.near.data(), b.occlusion.data(), zp, slicing, b.product.data(), b.sum.data(),
                 b.largest.data());
    } else {
      const size_t a = kernels_meeting_texture(m, b.cx.data(), b.cy.data(), b.side.data(), setup_.R, b.meets.data(),
                                               b.meets_cx.data(), b.meets_cy.data(), b.meets_side.data());
      n.lookups += m - a;  // lookups of 0 outside the texture, not made
      n.outside += m - a;
      if (a > 0) {
        filter.squares(k, a, b.meets_cx.data(), b.meets_cy.data(), b.meets_side.data(), b.occlusion.data(), n);
        accumulate_at(a, b.meets.data(), b.z.data(), b.near.data(), b.occlusion.data(), zp, slicing,
                      b.product.data(), b.sum.data(), b.largest.data());
      }
    }
  }
  for (size_t i = 0; i < count; ++i)
    out[b.target[i]] = !(b.z[i] > 0) ? 0.0f : (has_casters_ ? shader::ot_combine(setup_, {b.product[i], b.sum[i], b.largest[i]}) : 1.0f);
}

template <class F>
bool OcclusionTextures::tiled_point(const F& filter, Vec3f p, bool open, float near_z, float* v,
                                    LookupCounters& n) const {
  if (tiles_side_ <= 1 || !has_casters_) return false;
  const Vec3f q = p - light_.center;
  const float z = dot(q, light_.forward);
  if (!(z > 0)) return false;
  const float* tiles = reinterpret_cast<const float*>(tiles_.data());
  const float u = dot(q, setup_.right), w = dot(q, setup_.up);
  const shader::OtTileRange reach = shader::ot_reach(setup_, u, w, z);
  if (shader::ot_reach_is_whole(setup_, tiles, reach)) return false;
  // ot_visibility's tiled path, with the reach found above.
  shader::OtCounters c{};
  *v = shader::ot_visibility_tiled(setup_, tiles, filter.shared(), reinterpret_cast<const float*>(slice_bounds_.data()),
                                   u, w, z, near_z, reach, open, c);
  n.lookups += c.lookups, n.reads += c.reads, n.outside += c.outside, n.strips += c.strips;
  return true;
}

float OcclusionTextures::visibility(Vec3f p, LookupCounters* counters, bool open, float near_z) const {
  LookupCounters local;
  LookupCounters& n = counters ? *counters : local;
  float tiled = 0;
  if (dispatch([&](const auto& f) { return tiled_point(f, p, open, near_z, &tiled, n); })) return tiled;
  Batch b;
  b.reset(1);
  b.points[0] = p;
  b.targets[0] = 0;
  b.horizon[0] = 1.0f;
  b.near_z[0] = near_z;
  float v = 0;
  dispatch([&](const auto& f) { shade_batch(f, b, open, std::span<float>(&v, 1), n); });
  return v;
}

// Shading walks the image in 16 x 16 pixel tiles and, within a tile, slice by slice: the
// kernels of a tile's samples on one slice cover a small patch of one texture plane that
// stays in cache, and the per-sample arithmetic runs over arrays (vectorised). The same code
// as visibility() (a batch of one).
template <class F>
void OcclusionTextures::shade_with(const F& filter, const Scene& scene, const ViewSamples& vs,
                                   std::span<float> visibility, std::span<const float> near,
                                   LookupCounters& total) const {
  // The rendered window (the whole image, or a crop): its rows and tiles. Samples keep their
  // global pixel index y * width + x.
  const PixelWindow window = vs.traced_window();
  const int W = vs.width, H = window.height();
  // row[y] = the first sample of the window's row y (samples are grouped by pixel in scanline
  // order); a tile finds its samples in each row by binary search.
  std::vector<uint32_t> row(static_cast<size_t>(H) + 1, 0);
  {
    size_t i = 0;
    for (int y = 0; y <= H; ++y) {
      const uint64_t start = static_cast<uint64_t>(window.y0 + y) * W + window.x0;
      while (i < vs.size() && vs.samples[i].pixel < start) ++i;
      row[y] = static_cast<uint32_t>(i);
    }
  }
  auto first_at_or_after = [&](int y, int x) {
    const uint32_t pixel = static_cast<uint32_t>((window.y0 + y) * W + window.x0 + x);
    const ViewSample* b = vs.samples.data() + row[y];
    const ViewSample* e = vs.samples.data() + row[y + 1];
    return static_cast<uint32_t>(
        std::lower_bound(b, e, pixel, [](const ViewSample& s, uint32_t p) { return s.pixel < p; }) - vs.samples.data());
  };
  std::atomic<uint64_t> lookups{0}, reads{0}, outside{0}, strips{0};
  tbb::enumerable_thread_specific<Batch> batches;
  constexpr int kTile = 16;
  // Tiles of the window (x, y relative to its corner); a point's V does not depend on the
  // other points of its batch.
  parallel_for_tiles(window.width(), H, kTile, [&](int x0, int y0, int x1, int y1) {
    Batch& b = batches.local();
    uint32_t begin[kTile], end[kTile];
    size_t n = 0;
    for (int y = y0; y < y1; ++y) {
      begin[y - y0] = first_at_or_after(y, x0);
      end[y - y0] = x1 < window.width() ? first_at_or_after(y, x1) : row[y + 1];
      n += end[y - y0] - begin[y - y0];
    }
    LookupCounters counters;
    // Receivers on closed objects, then those on open surfaces: each kind its own fade-in
    // (occlusion_shared.h ot_slicing), a batch each.
    for (const bool open : {false, true}) {
      b.reset(n);
      size_t j = 0;
      for (int y = y0; y < y1; ++y)
        for (uint32_t i = begin[y - y0]; i < end[y - y0]; ++i) {
          const ViewSample& s = vs.samples[i];
          const bool closed = scene.objects[s.object].closed;
          if (closed == open) continue;
          const float h = shader::ot_horizon(setup_, s.p, s.ng, closed);
          if (!(h > 0)) {  // all of the light is behind the receiver's own surface
            visibility[i] = 0;
            continue;
          }
          const float near_z = near.empty() ? 0.0f : shader::ot_near_field_depth(setup_, s.p, near[i]);
          // Kernels reaching a tile with slices of its own: the tiles' pieces, point by point (the
          // GPU's function); the others in the batch, slice by slice.
          if (float v = 0; tiled_point(filter, s.p, open, near_z, &v, counters)) {
            visibility[i] = v * h;
            continue;
          }
          b.points[j] = s.p;
          b.targets[j] = i;
          b.horizon[j] = h;
          b.near_z[j] = near_z;
          ++j;
        }
      b.reset(j);
      shade_batch(filter, b, open, visibility, counters);
      for (size_t k = 0; k < j; ++k) visibility[b.targets[k]] *= b.horizon[k];
    }
    lookups.fetch_add(counters.lookups, std::memory_order_relaxed);
    reads.fetch_add(counters.reads, std::memory_order_relaxed);
    outside.fetch_add(counters.outside, std::memory_order_relaxed);
    strips.fetch_add(counters.strips, std::memory_order_relaxed);
  });
  total.lookups += lookups.load();
  total.reads += reads.load();
  total.outside += outside.load();
  total.strips += strips.load();
}

float OcclusionTextures::own_slice_visibility(Vec3f p, Vec3f ng, float near_z) const {
  const DepthBinMasks& depths = own_slice_depths();
  if (!own_slice_active_ || !has_casters_ || depths.nearest.empty()) return 1.0f;
  return shader::ot_own_slice(setup_, reinterpret_cast<const float*>(tiles_.data()), depths.nearest.data(),
                              own_slice_scale_, p, ng, near_z);
}

void OcclusionTextures::shade(const Scene& scene, const ViewSamples& vs, std::span<float> visibility,
                              MethodStats* stats, const RayTracer* tracer) const {
  Timer timer;
  LookupCounters n;
  const bool near_field = tracer && options_.near_field > 0 && has_casters_;
  // Each view sample's near field, once: the slices leave its depth out (shade_with), the ray
  // below traces it.
  std::vector<float> near(near_field ? vs.size() : 0, 0.0f);
  if (near_field)
    parallel_for(vs.size(), 4096, [&](size_t b, size_t e) {
      for (size_t i = b; i < e; ++i) {
        const ViewSample& s = vs.samples[i];
        near[i] = shader::ot_near_field_length(setup_, s.p, s.ng, scene.objects[s.object].closed);
      }
    });
  dispatch([&](const auto& f) { shade_with(f, scene, vs, visibility, near, n); });
  std::atomic<uint64_t> near_rays{0};
  if ((own_slice_active_ && has_casters_) || near_field) {
    // The receiver's own slice, for points on open surfaces; then each lit point's near field,
    // traced toward the light's centre (a stream of rays per range).
    parallel_for(vs.size(), 4096, [&](size_t b, size_t e) {
      std::vector<ShadowRay> rays;
      std::vector<uint32_t> traced;
      for (size_t i = b; i < e; ++i) {
        const ViewSample& s = vs.samples[i];
        const bool closed = scene.objects[s.object].closed;
        const float near_length = near_field ? near[i] : 0.0f;
        if (visibility[i] > 0 && !closed && own_slice_active_)
          visibility[i] *= own_slice_visibility(s.p, s.ng, shader::ot_near_field_depth(setup_, s.p, near_length));
        if (visibility[i] > 0 && near_length > 0) {
          ShadowRay r = shadow_ray_to(s.p, s.ng, setup_.center);
          r.tfar = std::min(r.tfar, near_length);
          rays.push_back(r);
          traced.push_back(static_cast<uint32_t>(i));
        }
      }
      if (rays.empty()) return;
      std::vector<float> transmit(rays.size());
      tracer->transmittance(rays, transmit);
      for (size_t j = 0; j < rays.size(); ++j) visibility[traced[j]] *= transmit[j];
      near_rays += rays.size();
    });
  }
  stats->add_phase("shading", timer.elapsed_ms());
  stats->texels_visited += n.reads;
  stats->add_count("lookups", n.lookups);
  stats->add_count("lookups_outside", n.outside);
  stats->add_count("lookups_strips", n.strips);
  stats->add_count("near_field_rays", near_rays.load());
}

}  // namespace penumbra::occlusion
