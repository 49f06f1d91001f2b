#include "penumbra/trace/ray_tracer.h"
#include "penumbra/trace/ray_shared.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <unordered_map>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/core/timer.h"

namespace penumbra {

namespace {

// The bytes Embree's device holds (its memory monitor: BVHs, vertex and index buffers, build
// scratch while a build runs).
std::atomic<int64_t> g_embree_bytes{0};
bool count_embree_bytes(void*, ssize_t bytes, bool) {
  g_embree_bytes += bytes;
  return true;
}

// One Embree device for the process: creating a device spins up its own thread state.
RTCDevice shared_device() {
  static RTCDevice device = [] {
    RTCDevice d = rtcNewDevice(nullptr);
    if (!d) throw Error("Embree: cannot create a device (error {})", static_cast<int>(rtcGetDeviceError(nullptr)));
    rtcSetDeviceMemoryMonitorFunction(d, count_embree_bytes, nullptr);
    return d;
  }();
  return device;
}

// Per-object data the filters read: the occlusion filter to attenuate shadow rays, the
// intersection filter to let camera rays through an alpha mask's holes. An object placing a
// shared mesh reads that mesh's opacities and texture coordinates (its triangles, in the
// mesh's own order: a filter sees the instanced geometry's primitive and barycentrics).
struct TransparencyData {
  bool transparent = false;           // some ray may find the surface less than opaque
  float opacity = 1.0f;               // material opacity
  const float* triangle_opacity = nullptr;  // optional, per triangle
  // Alpha texture (issue 20): the material's, and each triangle's three texture coordinates
  // (copied, so a refit that replaces the scene's meshes leaves them valid; for a shared mesh,
  // its prototype's, one copy for all its objects).
  SurfaceAlpha alpha;
  const Vec2f* corner_uvs = nullptr;
  std::vector<Vec2f> own_corner_uvs;  // an object of its own: the copy corner_uvs points to
  Vec2f uv(unsigned prim, float b1, float b2) const { return interpolate_uv(&corner_uvs[3 * static_cast<size_t>(prim)], b1, b2); }
  // The opacity the surface stops a shadow ray with at the hit (b1, b2) of triangle prim.
  float opacity_at(unsigned prim, float b1, float b2) const {
    float a = opacity * (triangle_opacity ? triangle_opacity[prim] : 1.0f);
    if (alpha.active() && a > 0) a *= alpha.opacity(uv(prim, b1, b2));
    return a;
  }
};

// A ray that crosses exactly an edge shared by two triangles is reported on both (Embree's
// watertight test guarantees no gap, not no overlap): the filter remembers the last few
// surfaces each ray crossed and attenuates once per surface.
struct RecentHits {
  static constexpr int kSize = 4;
  float t[kSize];
  unsigned object[kSize];
  int next = 0, count = 0;
  bool seen(float hit_t, unsigned o) const {
    float eps = 1e-5f * std::max(1.0f, hit_t);
    for (int i = 0; i < count; ++i)
      if (object[i] == o && std::abs(t[i] - hit_t) <= eps) return true;
    return false;
  }
  void add(float hit_t, unsigned o) {
    t[next] = hit_t;
    object[next] = o;
    next = (next + 1) % kSize;
    count = std::min(count + 1, kSize);
  }
};

// The intersect context extended with the per-ray state of the current batch (Embree
// passes the context pointer through to filter functions).
struct TransmittanceContext {
  RTCIntersectContext base;
  float* transmittance;  // indexed by RTCRay::id
  RecentHits* recent;    // indexed by RTCRay::id
};

// The object of a filter's candidate hit: the instance's (an object placing a shared mesh) or
// the geometry's (an object of its own in the top level). Both IDs are object indices, and
// every filtered geometry's user data is the per-object TransparencyData array.
inline const TransparencyData& filter_object(const RTCFilterFunctionNArguments* args, unsigned i, unsigned* object) {
  const unsigned inst = RTCHitN_instID(args->hit, args->N, i, 0);
  *object = inst != RTC_INVALID_GEOMETRY_ID ? inst : RTCHitN_geomID(args->hit, args->N, i);
  return static_cast<const TransparencyData*>(args->geometryUserPtr)[*object];
}

// Occlusion filter for semi-transparent geometry: multiply the ray's transmittance by
// (1 - opacity) of each surface it crosses and let it continue, unless nothing is left.
void transparency_filter(const RTCFilterFunctionNArguments* args) {
  auto* ctx = reinterpret_cast<TransmittanceContext*>(args->context);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] != -1) continue;
    unsigned object = 0;
    const TransparencyData& data = filter_object(args, i, &object);
    if (!data.transparent) continue;  // an opaque object placing a mesh another makes transparent
    unsigned id = RTCRayN_id(args->ray, args->N, i);
    unsigned prim = RTCHitN_primID(args->hit, args->N, i);
    float hit_t = RTCRayN_tfar(args->ray, args->N, i);
    const float a = data.opacity_at(prim, RTCHitN_u(args->hit, args->N, i), RTCHitN_v(args->hit, args->N, i));
    if (!(a > 0)) {  // a hole of an alpha mask: nothing there
      args->valid[i] = 0;
      continue;
    }
    RecentHits& recent = ctx->recent[id];
    if (recent.seen(hit_t, object)) {  // the same surface through a shared edge
      args->valid[i] = 0;
      continue;
    }
    recent.add(hit_t, object);
    float& t = ctx->transmittance[id];
    t *= (1.0f - a);
    if (t > kOpaqueCutoff) args->valid[i] = 0;  // reject the hit: keep tracing
    else t = 0.0f;                               // accept: the ray is blocked
  }
}

// Intersection filter of alpha-textured geometry: a camera ray passes through where the
// surface is not seen (SurfaceAlpha::seen: a mask's holes, a blend surface below its cutoff).
void alpha_intersect_filter(const RTCFilterFunctionNArguments* args) {
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] != -1) continue;
    unsigned object = 0;
    const TransparencyData& data = filter_object(args, i, &object);
    if (!data.corner_uvs) continue;  // not alpha-textured (another object of its mesh is)
    const unsigned prim = RTCHitN_primID(args->hit, args->N, i);
    const Vec2f uv = data.uv(prim, RTCHitN_u(args->hit, args->N, i), RTCHitN_v(args->hit, args->N, i));
    if (!data.alpha.seen(uv)) args->valid[i] = 0;
  }
}

}  // namespace

// An object placing a shared mesh, traced as an Embree instance of the mesh's prototype: how
// its hits come back to world space. The object's mesh is the shared mesh transformed by the
// placement M, and TriangleMesh::transform swaps two indices of every triangle where M
// mirrors; so the world triangle's geometric normal is sign(det M) cof(M) Ng (cof(M) =
// det(M) M^-T: (M a) x (M b) = cof(M) (a x b)), and where M mirrors its barycentrics of
// vertices 1 and 2 are the instance's swapped.
struct InstanceData {
  int prototype = -1;  // into Impl::prototypes; -1: an object of its own in the top level
  bool mirrored = false;
  float normal[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};  // sign(det M) cof(M)
  void set_placement(const Mat4& m) {
    const auto& a = m.m;
    float c[3][3];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        // The cofactor of a[i][j]: the 2 x 2 minor of the other rows and columns, cyclically.
        const int i1 = (i + 1) % 3, i2 = (i + 2) % 3, j1 = (j + 1) % 3, j2 = (j + 2) % 3;
        c[i][j] = a[i1][j1] * a[i2][j2] - a[i1][j2] * a[i2][j1];
      }
    const float det = a[0][0] * c[0][0] + a[0][1] * c[0][1] + a[0][2] * c[0][2];
    mirrored = det < 0;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) normal[i][j] = mirrored ? -c[i][j] : c[i][j];
  }
  Vec3f world_normal(Vec3f n) const {
    return {normal[0][0] * n.x + normal[0][1] * n.y + normal[0][2] * n.z,
            normal[1][0] * n.x + normal[1][1] * n.y + normal[1][2] * n.z,
            normal[2][0] * n.x + normal[2][1] * n.y + normal[2][2] * n.z};
  }
};

// A shared mesh placed by several objects: built once into an Embree scene of its own (one
// BVH), which every object placing it instances.
struct Prototype {
  std::shared_ptr<const TriangleMesh> mesh;  // kept: the filters read its opacities
  RTCScene scene = nullptr;
  std::vector<Vec2f> corner_uvs;  // when some object placing it is alpha-textured
};

struct RayTracer::Impl {
  RTCScene scene = nullptr;
  std::vector<TransparencyData> transparency;  // per object (stable addresses)
  std::vector<InstanceData> instance;          // per object
  std::vector<Prototype> prototypes;
  std::vector<bool> movable;                   // per object: built refittable (empty: none)
  std::vector<size_t> vertices, triangles;     // per object, as built
  void release() {
    if (scene) rtcReleaseScene(scene);
    scene = nullptr;
    for (Prototype& p : prototypes)
      if (p.scene) rtcReleaseScene(p.scene);
    prototypes.clear();
  }
  ~Impl() { release(); }
  bool two_level() const { return !movable.empty(); }
  bool read_hit(const RTCRayHit& rh, Hit* hit) const;
};

namespace {
// An object's vertices into its Embree vertex buffer.
void copy_positions(const TriangleMesh& m, float* v) {
  for (size_t i = 0; i < m.positions.size(); ++i) {
    v[3 * i] = m.positions[i].x; v[3 * i + 1] = m.positions[i].y; v[3 * i + 2] = m.positions[i].z;
  }
}

// A triangle geometry holding `m`'s vertices and triangles.
RTCGeometry new_triangle_geometry(RTCDevice device, const TriangleMesh& m) {
  RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                        3 * sizeof(float), m.positions.size()));
  copy_positions(m, v);
  auto* idx = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                             3 * sizeof(uint32_t), m.triangle_count()));
  std::memcpy(idx, m.indices.data(), m.indices.size() * sizeof(uint32_t));
  return geom;
}

// The object's material over the triangles of `m` (its own mesh, or the shared mesh it
// places): what the filters need, and whether it needs them.
void set_transparency(const SceneObject& obj, const TriangleMesh& m, TransparencyData* td) {
  const bool textured = obj.material.alpha_textured() && m.uvs.size() == m.positions.size();
  td->transparent = obj.material.opacity < 1.0f || textured ||
                    std::any_of(m.triangle_opacity.begin(), m.triangle_opacity.end(), [](float a) { return a < 1.0f; });
  if (!td->transparent) return;
  td->opacity = obj.material.opacity;
  td->triangle_opacity = m.triangle_opacity.empty() ? nullptr : m.triangle_opacity.data();
  if (textured) td->alpha = obj.material.alpha;
}

// Embree's row-major 3 x 4 transform of an affine matrix.
void set_instance_transform(RTCGeometry inst, const Mat4& m) {
  float xfm[12];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) xfm[4 * r + c] = m.m[r][c];
  rtcSetGeometryTransform(inst, 0, RTC_FORMAT_FLOAT3X4_ROW_MAJOR, xfm);
}
}  // namespace

// ray_shared.h: the GPU's rays leave and end where these do.
Vec3f offset_ray_origin(Vec3f p, Vec3f ng, Vec3f dir) { return shader::offset_ray_origin_shared(p, ng, dir); }

ShadowRay shadow_ray_to(Vec3f p, Vec3f ng, Vec3f q) {
  ShadowRay r;
  shader::shadow_segment(p, ng, q, r.org, r.dir, r.tfar);
  r.tnear = 0.0f;
  return r;
}

RayTracer::RayTracer(const Scene& scene, std::span<const uint32_t> movable) : impl_(std::make_unique<Impl>()) {
  if (!movable.empty()) {
    impl_->movable.assign(scene.objects.size(), false);
    for (uint32_t o : movable) {
      if (o >= scene.objects.size()) throw Error("RayTracer: movable object {} of {}", o, scene.objects.size());
      impl_->movable[o] = true;
    }
  }
  build(scene);
}

void RayTracer::build(const Scene& scene) {
  Timer timer;
  RTCDevice device = shared_device();
  impl_->release();
  const int64_t bytes_before = g_embree_bytes.load();
  impl_->scene = rtcNewScene(device);
  has_transparency_ = false;
  triangle_count_ = stored_triangle_count_ = 0;
  geometry_count_ = instance_count_ = 0;
  if (impl_->two_level()) {
    // Embree 3 builds a two-level BVH (one per geometry, then one over the geometries) for a
    // scene of build quality LOW: only then does it keep the per-geometry BVHs across commits,
    // rebuilding those of modified geometries, and refit those of quality REFIT.
    rtcSetSceneFlags(impl_->scene, RTC_SCENE_FLAG_DYNAMIC);
    rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_LOW);
  } else {
    rtcSetSceneFlags(impl_->scene, RTC_SCENE_FLAG_NONE);
    rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_MEDIUM);  // no spatial splits: a filter sees each triangle once
  }
  const size_t n = scene.objects.size();
  impl_->transparency.assign(n, TransparencyData{});
  impl_->instance.assign(n, InstanceData{});
  impl_->vertices.assign(n, 0);
  impl_->triangles.assign(n, 0);

  // Shared meshes placed by two or more objects become prototypes (SceneObject::shared_mesh);
  // a mesh placed once stays in the top level, where tracing it costs no second level.
  std::unordered_map<const TriangleMesh*, int> users;
  for (const SceneObject& o : scene.objects)
    if (o.shared_mesh) ++users[o.shared_mesh.get()];
  std::unordered_map<const TriangleMesh*, int> prototype_of;
  for (size_t id = 0; id < n; ++id) {
    const SceneObject& obj = scene.objects[id];
    if (!obj.shared_mesh || users[obj.shared_mesh.get()] < 2) continue;
    auto [it, first] = prototype_of.try_emplace(obj.shared_mesh.get(), static_cast<int>(impl_->prototypes.size()));
    if (first) impl_->prototypes.push_back(Prototype{obj.shared_mesh, nullptr, {}});
    impl_->instance[id].prototype = it->second;
  }

  // Each object's transparency, over the triangles Embree holds for it.
  std::vector<bool> prototype_transparent(impl_->prototypes.size(), false), prototype_textured = prototype_transparent;
  for (size_t id = 0; id < n; ++id) {
    const SceneObject& obj = scene.objects[id];
    const int p = impl_->instance[id].prototype;
    TransparencyData& td = impl_->transparency[id];
    set_transparency(obj, p >= 0 ? *obj.shared_mesh : obj.mesh, &td);
    has_transparency_ = has_transparency_ || td.transparent;
    if (p < 0) continue;
    prototype_transparent[p] = prototype_transparent[p] || td.transparent;
    prototype_textured[p] = prototype_textured[p] || td.alpha.active();
  }

  // The prototypes: one Embree scene (one BVH) per shared mesh, its filters where some object
  // placing it needs them (they look the object up by its instance ID).
  for (size_t p = 0; p < impl_->prototypes.size(); ++p) {
    Prototype& proto = impl_->prototypes[p];
    const TriangleMesh& m = *proto.mesh;
    proto.scene = rtcNewScene(device);
    rtcSetSceneBuildQuality(proto.scene, RTC_BUILD_QUALITY_MEDIUM);  // no spatial splits, as the top level
    RTCGeometry geom = new_triangle_geometry(device, m);
    if (prototype_textured[p]) {
      proto.corner_uvs = m.corner_uvs();
      rtcSetGeometryIntersectFilterFunction(geom, alpha_intersect_filter);
    }
    if (prototype_transparent[p]) {
      rtcSetGeometryUserData(geom, impl_->transparency.data());
      rtcSetGeometryOccludedFilterFunction(geom, transparency_filter);
    }
    rtcCommitGeometry(geom);
    rtcAttachGeometry(proto.scene, geom);
    rtcReleaseGeometry(geom);
    rtcCommitScene(proto.scene);
    ++geometry_count_;
    stored_triangle_count_ += m.triangle_count();
  }

  for (size_t id = 0; id < n; ++id) {
    const SceneObject& obj = scene.objects[id];
    const TriangleMesh& m = obj.mesh;
    TransparencyData& td = impl_->transparency[id];
    InstanceData& inst = impl_->instance[id];
    RTCGeometry geom = nullptr;
    if (inst.prototype >= 0) {
      const Prototype& proto = impl_->prototypes[inst.prototype];
      if (td.alpha.active()) td.corner_uvs = proto.corner_uvs.data();
      geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_INSTANCE);
      rtcSetGeometryInstancedScene(geom, proto.scene);
      set_instance_transform(geom, obj.placement);
      inst.set_placement(obj.placement);
      ++instance_count_;
    } else {
      geom = new_triangle_geometry(device, m);
      if (impl_->two_level())  // each object's own BVH: SAH without spatial splits, refit where it moves
        rtcSetGeometryBuildQuality(geom, impl_->movable[id] ? RTC_BUILD_QUALITY_REFIT : RTC_BUILD_QUALITY_MEDIUM);
      if (td.alpha.active()) {
        td.own_corner_uvs = m.corner_uvs();
        td.corner_uvs = td.own_corner_uvs.data();
        rtcSetGeometryIntersectFilterFunction(geom, alpha_intersect_filter);
      }
      if (td.transparent) {
        rtcSetGeometryUserData(geom, impl_->transparency.data());
        rtcSetGeometryOccludedFilterFunction(geom, transparency_filter);
      }
      ++geometry_count_;
      stored_triangle_count_ += m.triangle_count();
    }
    rtcCommitGeometry(geom);
    rtcAttachGeometryByID(impl_->scene, geom, static_cast<unsigned>(id));
    rtcReleaseGeometry(geom);
    triangle_count_ += m.triangle_count();
    impl_->vertices[id] = m.positions.size();
    impl_->triangles[id] = m.triangle_count();
  }
  rtcCommitScene(impl_->scene);
  if (rtcGetDeviceError(device) != RTC_ERROR_NONE) throw Error("Embree: scene build failed");
  memory_bytes_ = static_cast<size_t>(std::max<int64_t>(0, g_embree_bytes.load() - bytes_before));
  build_ms_ = timer.elapsed_ms();
}

RayTracer::~RayTracer() = default;

nlohmann::json RayTracer::stats_json() const {
  return {{"build_ms", build_ms_},           {"bytes", memory_bytes_},
          {"triangles", triangle_count_},    {"stored_triangles", stored_triangle_count_},
          {"geometries", geometry_count_},   {"instances", instance_count_}};
}

void RayTracer::update_objects(const Scene& scene, std::span<const uint32_t> objects) {
  Timer timer;
  if (scene.objects.size() != impl_->transparency.size())
    throw Error("RayTracer::update_objects: {} objects, built with {}", scene.objects.size(), impl_->transparency.size());
  // An instance moves by its transform alone, if it still places the mesh it was built with. A
  // refit keeps each BVH's topology: only for movable objects with the vertices and triangles
  // they were built with.
  bool refit = true;
  for (uint32_t o : objects) {
    if (o >= scene.objects.size()) throw Error("RayTracer::update_objects: object {} of {}", o, scene.objects.size());
    const SceneObject& obj = scene.objects[o];
    if (const int p = impl_->instance[o].prototype; p >= 0) {
      refit = refit && obj.shared_mesh == impl_->prototypes[p].mesh;
      continue;
    }
    const TriangleMesh& m = obj.mesh;
    refit = refit && impl_->two_level() && impl_->movable[o] && m.positions.size() == impl_->vertices[o] &&
            m.triangle_count() == impl_->triangles[o];
  }
  // The transparency filter reads the per-triangle opacities of `scene` from now on (an
  // instance reads its shared mesh's, which the tracer keeps).
  for (size_t o = 0; o < scene.objects.size(); ++o)
    if (impl_->transparency[o].triangle_opacity && impl_->instance[o].prototype < 0)
      impl_->transparency[o].triangle_opacity = scene.objects[o].mesh.triangle_opacity.data();
  if (!refit) {
    build(scene);
    ++rebuilds_;
    return;
  }
  for (uint32_t o : objects) {
    RTCGeometry geom = rtcGetGeometry(impl_->scene, o);
    if (impl_->instance[o].prototype >= 0) {
      set_instance_transform(geom, scene.objects[o].placement);
      impl_->instance[o].set_placement(scene.objects[o].placement);
      rtcCommitGeometry(geom);
      continue;
    }
    const TriangleMesh& m = scene.objects[o].mesh;
    auto* v = static_cast<float*>(rtcGetGeometryBufferData(geom, RTC_BUFFER_TYPE_VERTEX, 0));
    copy_positions(m, v);
    rtcUpdateGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0);
    // A transform that starts or stops mirroring swaps two indices per triangle
    // (TriangleMesh::transform). Embree rebuilds (rather than refits) a geometry whose index
    // buffer was updated, so it is updated only then.
    void* idx = rtcGetGeometryBufferData(geom, RTC_BUFFER_TYPE_INDEX, 0);
    if (std::memcmp(idx, m.indices.data(), m.indices.size() * sizeof(uint32_t)) != 0) {
      std::memcpy(idx, m.indices.data(), m.indices.size() * sizeof(uint32_t));
      rtcUpdateGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0);
    }
    rtcCommitGeometry(geom);
  }
  rtcCommitScene(impl_->scene);
  if (rtcGetDeviceError(shared_device()) != RTC_ERROR_NONE) throw Error("Embree: scene refit failed");
  ++refits_;
  refit_ms_ += timer.elapsed_ms();
}

namespace {
// An Embree ray-hit record for `ray`, no hit yet.
inline void fill_ray_hit(RTCRayHit& rh, const Ray& ray, unsigned id) {
  rh.ray.org_x = ray.org.x; rh.ray.org_y = ray.org.y; rh.ray.org_z = ray.org.z;
  rh.ray.dir_x = ray.dir.x; rh.ray.dir_y = ray.dir.y; rh.ray.dir_z = ray.dir.z;
  rh.ray.tnear = ray.tnear;
  rh.ray.tfar = ray.tfar;
  rh.ray.mask = 0xFFFFFFFFu;
  rh.ray.flags = 0;
  rh.ray.time = 0;
  rh.ray.id = id;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
}

}  // namespace

// The hit of a traced record (false, `hit` untouched, if the ray hit nothing). A hit through an
// instance is the object's world triangle: Embree reports the shared mesh's triangle, its
// barycentrics and its normal in the mesh's own space (InstanceData).
bool RayTracer::Impl::read_hit(const RTCRayHit& rh, Hit* hit) const {
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;
  hit->t = rh.ray.tfar;
  hit->prim = rh.hit.primID;
  hit->ng = {rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z};
  const unsigned inst = rh.hit.instID[0];
  if (inst == RTC_INVALID_GEOMETRY_ID) {
    hit->object = rh.hit.geomID;
    hit->u = rh.hit.u;
    hit->v = rh.hit.v;
    return true;
  }
  const InstanceData& d = instance[inst];
  hit->object = inst;
  hit->ng = d.world_normal(hit->ng);
  hit->u = d.mirrored ? rh.hit.v : rh.hit.u;
  hit->v = d.mirrored ? rh.hit.u : rh.hit.v;
  return true;
}

bool RayTracer::intersect(const Ray& ray, Hit* hit) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRayHit rh;
  fill_ray_hit(rh, ray, 0);
  rtcIntersect1(impl_->scene, &ctx, &rh);
  return impl_->read_hit(rh, hit);
}

void RayTracer::intersect(std::span<const Ray> rays, std::span<Hit> hits, bool coherent) const {
  if (hits.size() < rays.size()) throw Error("RayTracer::intersect: output too small");
  constexpr size_t kChunk = 256;
  RTCRayHit buf[kChunk];
  for (size_t begin = 0; begin < rays.size(); begin += kChunk) {
    const size_t n = std::min(kChunk, rays.size() - begin);
    for (size_t i = 0; i < n; ++i) fill_ray_hit(buf[i], rays[begin + i], static_cast<unsigned>(i));
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    if (coherent) ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    rtcIntersect1M(impl_->scene, &ctx, buf, static_cast<unsigned>(n), sizeof(RTCRayHit));
    for (size_t i = 0; i < n; ++i) {
      Hit& hit = hits[begin + i];
      if (!impl_->read_hit(buf[i], &hit)) {
        hit = Hit{};
        hit.object = Hit::kMiss;
      }
    }
  }
}

namespace {
inline void fill_ray(RTCRay& r, const ShadowRay& s, unsigned id) {
  r.org_x = s.org.x; r.org_y = s.org.y; r.org_z = s.org.z;
  r.dir_x = s.dir.x; r.dir_y = s.dir.y; r.dir_z = s.dir.z;
  r.tnear = s.tnear;
  r.tfar = s.tfar;
  r.mask = 0xFFFFFFFFu;
  r.flags = 0;
  r.time = 0;
  r.id = id;
}
}  // namespace

bool RayTracer::occluded(const ShadowRay& ray) const { return transmittance(ray) < 1.0f; }

float RayTracer::transmittance(const ShadowRay& ray) const {
  float t = 1.0f;
  transmittance(std::span<const ShadowRay>(&ray, 1), std::span<float>(&t, 1));
  return t;
}

void RayTracer::transmittance(std::span<const ShadowRay> rays, std::span<float> out) const {
  if (out.size() < rays.size()) throw Error("RayTracer::transmittance: output too small");
  // Streams of up to 256 rays on the stack: rtcOccluded1M with an incoherent context.
  constexpr size_t kChunk = 256;
  RTCRay buf[kChunk];
  RecentHits recent[kChunk];
  for (size_t begin = 0; begin < rays.size(); begin += kChunk) {
    size_t n = std::min(kChunk, rays.size() - begin);
    TransmittanceContext ctx;
    rtcInitIntersectContext(&ctx.base);
    ctx.transmittance = out.data() + begin;
    ctx.recent = recent;
    for (size_t i = 0; i < n; ++i) {
      fill_ray(buf[i], rays[begin + i], static_cast<unsigned>(i));
      ctx.transmittance[i] = 1.0f;
      recent[i].count = recent[i].next = 0;
    }
    rtcOccluded1M(impl_->scene, &ctx.base, buf, static_cast<unsigned>(n), sizeof(RTCRay));
    for (size_t i = 0; i < n; ++i)
      if (buf[i].tfar == -kInfinity) ctx.transmittance[i] = 0.0f;
  }
}

void RayTracer::transmittance_fan(Vec3f p, Vec3f ng, const float* x, const float* y, const float* z, size_t n,
                                  float* out) const {
  // The offset of offset_ray_origin, computed once for the fan.
  const float eps = shader::ray_offset_epsilon(p);
  const Vec3f n_unit = shader::offset_normal(ng);
  // Incoherent streams of single rays (rtcOccluded1M): measured on bunny, plant and furball,
  // Embree 3.13's 4/8/16-wide packets with a coherent context trace these fans 1.8-2.6x
  // slower than single rays (docs/methods/reference.md), although the fan is as coherent
  // as shadow rays get; the packet traversal pays for lanes that finish early.
  constexpr size_t kChunk = 256;
  RTCRay rays[kChunk];
  RecentHits recent[kChunk];
  for (size_t b = 0; b < n; b += kChunk) {
    const size_t m = std::min(kChunk, n - b);
    for (size_t i = 0; i < m; ++i) {
      // ray_shared.h fan_segment: off the surface on the side the ray leaves into, the segment
      // t in [0, 1) ending just short of the light as shadow_ray_to's does.
      Vec3f org, dir;
      shader::fan_segment(p, n_unit, eps, Vec3f(x[b + i], y[b + i], z[b + i]), org, dir);
      RTCRay& r = rays[i];
      r.org_x = org.x;
      r.org_y = org.y;
      r.org_z = org.z;
      r.dir_x = dir.x;
      r.dir_y = dir.y;
      r.dir_z = dir.z;
      r.tnear = 0.0f;
      r.tfar = shader::kFanTfar;
      r.mask = 0xFFFFFFFFu;
      r.flags = 0;
      r.time = 0;
      r.id = static_cast<unsigned>(i);
      recent[i].count = recent[i].next = 0;
      out[b + i] = 1.0f;
    }
    TransmittanceContext ctx;
    rtcInitIntersectContext(&ctx.base);
    ctx.transmittance = out + b;
    ctx.recent = recent;
    rtcOccluded1M(impl_->scene, &ctx.base, rays, static_cast<unsigned>(m), sizeof(RTCRay));
    for (size_t i = 0; i < m; ++i)
      if (rays[i].tfar == -kInfinity) out[b + i] = 0.0f;
  }
}

}  // namespace penumbra
