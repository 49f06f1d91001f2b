// The shadow-map baselines: shadow-map against `hard`, PCF widening, PCSS bounds, limits
// and exact cases, xie2007 eq. 1, multi-view-sm converging to `reference`.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "penumbra/core/parallel.h"
#include "penumbra/eval/metrics.h"
#include "penumbra/raster/shadow_view.h"
#include "penumbra/render/renderer.h"
#include "penumbra/shadow/baseline/multi_view_shared.h"
#include "penumbra/shadow/shadow_map_common.h"
#include "penumbra/testing/memory_cases.h"
#include "penumbra/testing/test_scenes.h"
#include "penumbra/trace/ray_tracer.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using testing::ground_scene;
using testing::object;
using testing::quad_y;
using testing::rect_light_down;

Scene shipped(const char* name, int res) {
  Scene s = load_scene(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/" + name);
  s.camera.width = s.camera.height = res;
  return s;
}

Image render_v(const Scene& scene, const std::string& method, std::vector<std::string> params = {}, int spp = 16,
               uint64_t seed = 0) {
  RenderSettings settings;
  settings.method = method;
  settings.params = std::move(params);
  settings.light_samples = spp;
  settings.seed = seed;
  return render_scene(scene, settings).visibility;
}

int count_pixels(const Image& v, const std::function<bool(float)>& pred) {
  int n = 0;
  for (float x : v.data()) n += pred(x);
  return n;
}

// A small scene: ground, a 0.6 x 0.6 square at height 0.5 and a box standing on the ground,
// under a 1 x 1 rect light at height 2, seen from above.
Scene small_scene(int res) {
  std::vector<SceneObject> occluders;
  occluders.push_back(object(quad_y(0.5f, -0.7f, -0.1f, -0.3f, 0.3f)));
  occluders.push_back(object(testing::box({0.3f, 0, -0.2f}, {0.6f, 0.7f, 0.2f})));
  Scene s = ground_scene(std::move(occluders), rect_light_down({0, 2, 0}, 1.0f, 1.0f), res);
  s.camera = testing::top_camera(res, 4.0f, 40.0f);
  return s;
}

TEST(ShadowMap, EqualsHardOnContact) {
  Scene scene = shipped("contact.json", 96);
  Image hard = render_v(scene, "hard");
  Image sm = render_v(scene, "shadow-map", {"bilinear=false"});
  // Both are binary; they may differ only where the map's texels alias the shadow edge.
  EXPECT_EQ(count_pixels(sm, [](float v) { return v != 0.0f && v != 1.0f; }), 0);
  EXPECT_LE(fraction_above(sm, hard, 0.5), 0.01);
  int shadowed = count_pixels(hard, [](float v) { return v < 0.5f; });
  EXPECT_GT(shadowed, 96 * 96 / 10);  // the comparison is not vacuous
  // Compared with the point's own depth and no slope-scaled bias, the lit surfaces shadow
  // themselves (acne): the bias is what makes the map agree with the ray-traced shadow.
  Image acne = render_v(scene, "shadow-map", {"bias=0", "slope_bias=0", "receiver_plane=false", "bilinear=false"});
  EXPECT_GT(fraction_above(acne, hard, 0.5), 0.05);
  // Against the receiver plane (exact for these planar receivers) `bias=0` still gets the floor
  // of 64 float epsilons of the depth (sm_constant_bias), which is all rounding needs.
  Image floor_only = render_v(scene, "shadow-map", {"bias=0", "slope_bias=0", "bilinear=false"});
  EXPECT_LE(fraction_above(floor_only, hard, 0.5), 0.01);
}

// A street seen from one end under a light high over its middle (test_scenes.h): its nearer boxes
// cast their shadows 73-85 degrees off the light's axis, beyond max_fov's 60, while its far end
// keeps the window inside the cap. The fitted maps hold the receivers beyond the cap that a caster
// can shadow (shadow_map::shadow_reach); before, they counted lit.
TEST(ShadowMap, ReceiversBeyondMaxFovThatACasterCanShadowAreInTheMap) {
  const Scene street = testing::street_beyond_the_cap_scene(48);
  auto render = [&](const std::string& method) {
    RenderSettings s;
    s.method = method;
    s.seed = 7;
    s.light_samples = 64;
    return render_scene(street, s);
  };
  const RenderResult truth = render("reference");
  double shadow = 0;
  for (float v : truth.visibility.data()) shadow += 1 - v;
  shadow /= static_cast<double>(truth.visibility.data().size());
  EXPECT_GT(shadow, 0.005);
  // shadow-map and pcss were off by a third of the shadow (lit beyond the cap: 0.0163); now by
  // less than a tenth of it, afsm (exact per light sample) and afsm-hard (exact hard shadows)
  // within 10^-4 of their ray-traced answers. (vsm, evsm, msm keep the cap: their near field's
  // rays answer there; docs/methods/vsm.md.)
  for (const char* method : {"shadow-map", "pcss"}) {
    const double e = mean_absolute_error(render(method).visibility, truth.visibility);
    std::printf("%-10s on the street beyond the cap: mean |dV| %.5f (the shadow: %.5f)\n", method, e, shadow);
    EXPECT_LT(e, 0.1 * shadow) << method;
  }
  EXPECT_LT(mean_absolute_error(render("afsm").visibility, truth.visibility), 1e-4);
  EXPECT_LT(mean_absolute_error(render("afsm-hard").visibility, render("hard").visibility), 1e-4);
}

TEST(ShadowMap, BilinearRampsTheEdgesTowardTheRayTracedShadow) {
  // The default lookup weighs the 2 x 2 texels around the receiver: a one-texel ramp where the
  // nearest texel steps. Against the point-sampled shadow it is right wherever all four texels
  // agree and at most about half wrong across an edge, so fewer pixels disagree with `hard` by
  // more than half; and an area light's shadow is soft at every edge, so the ramp is nearer the
  // ground truth than the step.
  for (const char* file : {"contact.json", "bunny.json"}) {
    Scene scene = shipped(file, 96);
    Image hard = render_v(scene, "hard");
    Image truth = render_v(scene, "reference", {}, 256);
    Image nearest = render_v(scene, "shadow-map", {"resolution=256", "bilinear=false"});
    Image bilinear = render_v(scene, "shadow-map", {"resolution=256"});
    EXPECT_GT(count_pixels(bilinear, [](float v) { return v > 0.0f && v < 1.0f; }), 0) << file;
    EXPECT_LT(mean_absolute_error(bilinear, truth), mean_absolute_error(nearest, truth)) << file;
    EXPECT_LT(fraction_above(bilinear, hard, 0.5), fraction_above(nearest, hard, 0.5)) << file;
    // Pixels far from any edge see four equal texels: the two lookups agree there.
    EXPECT_LE(fraction_above(bilinear, nearest, 0.0), 0.25) << file;
  }
}

TEST(ShadowMap, BilinearIsTheBoxAtTexelCentres) {
  // shadow_map_visibility with `bilinear`: at a receiver on a texel centre the sliding box is
  // the plain (2 pcf + 1)^2 box of whole texels; half-way between two centres along x it is the
  // mean of the boxes at both (same receiver, so the same reference depths).
  Scene scene = shipped("contact.json", 64);
  RayTracer tracer(scene);
  ViewSamples vs = camera_pass(scene, tracer, 0);
  const AreaLight& light = scene.lights[0];
  const RasterTriangles tris = gather_raster_triangles(scene);
  Rasterizer rasterizer;
  shadow_map::ShadowDepthMap sm;
  sm.render(rasterizer, tris,
            shadow_map::light_view_from(light, light.center, shadow_map::receiver_points(vs, light), scene.bounds(),
                                        128, 120));
  const shader::ShadowBias b = shadow_map::BiasParams{}.shared();
  const DepthMap& map = sm.map();
  auto visibility = [&](Vec3f p, Vec3f ng, int pcf, bool bilinear) {
    uint32_t texels = 0;
    return shader::shadow_map_visibility(map.z.data(), map.opacity.data(), sm.shared(), b, pcf, bilinear,
                                         light.center, light.frame.n, p, ng, false, texels);
  };
  int partial = 0, checked = 0;
  for (int pcf : {0, 1, 2}) {
    for (int y = 10; y < 118; y += 3) {
      for (int x = 10; x < 118; x += 3) {
        // A receiver on the texel's ray, 0.9 of the way to the map's surface there, facing the light.
        LightView::TexelRay ray = sm.view().texel_ray({x + 0.5f, y + 0.5f});
        const float zt = map.z[static_cast<size_t>(y) * map.width + x];
        if (!std::isfinite(zt)) continue;
        const Vec3f ng = -normalize(ray.dir);
        const Vec3f p = ray.at(0.9f * zt);
        EXPECT_NEAR(visibility(p, ng, pcf, true), visibility(p, ng, pcf, false), 1e-3f) << x << " " << y;
        // Half-way to the next centre: the receiver's texel-space x moves by half a texel.
        LightView::TexelRay half = sm.view().texel_ray({x + 1.0f, y + 0.5f});
        const Vec3f q = half.at(0.9f * zt);
        const shadow_map::Receiver r = sm.receiver(q, ng, shadow_map::BiasParams{});
        float box[2] = {0, 0};
        for (int side = 0; side < 2; ++side)
          for (int dy = -pcf; dy <= pcf; ++dy)
            for (int dx = -pcf; dx <= pcf; ++dx)
              box[side] += sm.transmit_at(r, {x + side + dx + 0.5f, y + dy + 0.5f}, shadow_map::BiasParams{});
        const float expected = 0.5f * (box[0] + box[1]) / float((2 * pcf + 1) * (2 * pcf + 1));
        const float got = visibility(q, ng, pcf, true);
        EXPECT_NEAR(got, expected, 2e-3f) << x << " " << y << " pcf " << pcf;
        partial += got > 0.0f && got < 1.0f;
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 1000);
  EXPECT_GT(partial, 10);  // some of them straddle a shadow edge
}

TEST(ShadowMap, PcfWidensTheShadowMonotonically) {
  Scene scene = shipped("contact.json", 96);
  int last_touched = -1, last_umbra = 1 << 30;
  for (int pcf : {0, 1, 2, 4, 8}) {
    Image v = render_v(scene, "shadow-map", {"resolution=256", "bilinear=false", "pcf=" + std::to_string(pcf)});
    for (float x : v.data()) {
      ASSERT_GE(x, 0.0f);
      ASSERT_LE(x, 1.0f);
    }
    int touched = count_pixels(v, [](float x) { return x < 1.0f; });  // any shadow
    int umbra = count_pixels(v, [](float x) { return x == 0.0f; });
    int partial = count_pixels(v, [](float x) { return x > 0.0f && x < 1.0f; });
    if (pcf == 0) EXPECT_EQ(partial, 0);
    if (pcf > 0) {
      EXPECT_GT(touched, last_touched) << "pcf " << pcf;  // the shadow grows outward
      EXPECT_LE(umbra, last_umbra) << "pcf " << pcf;      // and the umbra shrinks
      EXPECT_GT(partial, 0);
    }
    last_touched = touched;
    last_umbra = umbra;
  }
}

TEST(Pcss, VisibilityIsInTheUnitIntervalAndSoft) {
  Scene scene = shipped("contact.json", 64);
  for (const char* variant : {"variant=fernando", "variant=xie2007"}) {
    Image v = render_v(scene, "pcss", {variant});
    for (float x : v.data()) {
      ASSERT_GE(x, 0.0f) << variant;
      ASSERT_LE(x, 1.0f) << variant;
    }
    EXPECT_GT(count_pixels(v, [](float x) { return x > 0.05f && x < 0.95f; }), 64 * 64 / 50) << variant;
  }
}

TEST(Pcss, ReducesToTheHardShadowForATinyLight) {
  Scene scene = shipped("contact.json", 96);
  scene.lights[0].size = scene.lights[0].size * 1e-4f;
  Image hard = render_v(scene, "hard");
  for (const char* variant : {"variant=fernando", "variant=xie2007"}) {
    Image v = render_v(scene, "pcss", {variant});
    EXPECT_LE(fraction_above(v, hard, 0.5), 0.01) << variant;
    EXPECT_LE(count_pixels(v, [](float x) { return x > 0.05f && x < 0.95f; }), 96 * 96 / 100) << variant;
  }
}

TEST(Pcss, ExactForOneOccluderParallelToTheLight) {
  // Light, occluder and receiver in parallel planes: every blocker lies at the average
  // blocker depth, so PCSS's planar assumption holds and its kernel (the light's shape
  // projected through the receiver onto the blocker plane) finds exactly the occluded
  // light points: it must agree with ray tracing up to sampling noise.
  Scene scene = ground_scene({object(quad_y(1.0f, -0.4f, 0.4f, -0.3f, 0.5f))}, rect_light_down({0, 2, 0}, 1.0f, 0.6f), 48);
  scene.camera = testing::top_camera(48, 4.0f, 45.0f);
  Image ref = render_v(scene, "reference", {}, 256);
  Image pcss = render_v(scene, "pcss", {"blocker_samples=64", "pcf_samples=256"});
  ErrorStats e = compare_images(pcss, ref);
  EXPECT_LT(e.mae, 0.01);
  EXPECT_LT(e.max_abs, 0.2);
  // The penumbra is really there.
  EXPECT_GT(count_pixels(ref, [](float x) { return x > 0.1f && x < 0.9f; }), 48 * 48 / 20);
}

// Distance from p to the segment [a, b].
float segment_distance(Vec3f p, Vec3f a, Vec3f b) {
  Vec3f ab = b - a;
  float t = std::clamp(dot(p - a, ab) / dot(ab, ab), 0.0f, 1.0f);
  return length(p - (a + ab * t));
}

TEST(Pcss, DepartsFromTheReferenceAtContactAndWhereOccludersOverlap) {
  // contact.json, regions of the ground (docs/methods/pcss.md):
  //  - contact: within 0.08 of the box's footprint outline or 0.12 of the ball's contact
  //    point (xie2007 §3: "loss of contact shadows");
  //  - overlap: in the shadow (V < 0.98) of the box alone *and* of the ball alone: the
  //    blocker search averages the two occluders' depths (wrong occluder fusion).
  // There PCSS must be measurably wrong, and multi-view-sm (the same maps' brute-force
  // version) right.
  const int res = 112;
  Scene scene = shipped("contact.json", res);
  ASSERT_EQ(scene.objects.size(), 3u);  // ground, box, ball
  RayTracer tracer(scene);
  ViewSamples vs = camera_pass(scene, tracer, 0);
  std::vector<Vec3f> foot;  // the box's bottom corners, in order around the footprint
  for (Vec3f v : scene.objects[1].mesh.positions)
    if (std::abs(v.y) < 1e-4f && std::none_of(foot.begin(), foot.end(), [&](Vec3f f) { return distance(f, v) < 1e-5f; }))
      foot.push_back(v);
  ASSERT_EQ(foot.size(), 4u);
  std::sort(foot.begin(), foot.end(), [](Vec3f a, Vec3f b) { return std::atan2(a.z, a.x) < std::atan2(b.z, b.x); });
  Scene box_only = scene, ball_only = scene;
  box_only.objects.erase(box_only.objects.begin() + 2);
  ball_only.objects.erase(ball_only.objects.begin() + 1);
  Image v_box = render_v(box_only, "reference", {}, 32), v_ball = render_v(ball_only, "reference", {}, 32);
  Image contact(res, res, 1, 0.0f), overlap(res, res, 1, 0.0f);
  for (const ViewSample& s : vs.samples) {
    if (s.object != 0) continue;
    float d = distance(s.p, Vec3f(0.55f, 0, 0.35f)) < 0.12f ? 0.0f : 1e9f;
    for (size_t i = 0; i < 4; ++i) d = std::min(d, segment_distance(s.p, foot[i], foot[(i + 1) % 4]));
    if (d < 0.08f) contact.data()[s.pixel] = 1;
    else if (v_box.data()[s.pixel] < 0.98f && v_ball.data()[s.pixel] < 0.98f) overlap.data()[s.pixel] = 1;
  }
  EXPECT_GT(count_pixels(contact, [](float x) { return x > 0; }), 80);
  EXPECT_GT(count_pixels(overlap, [](float x) { return x > 0; }), 300);
  Image ref = render_v(scene, "reference", {}, 256);
  Image mv = render_v(scene, "multi-view-sm", {}, 256);
  for (const char* variant : {"variant=fernando", "variant=xie2007"}) {
    Image pcss = render_v(scene, "pcss", {variant});
    for (const Image* mask : {&contact, &overlap}) {
      MetricOptions o;
      o.mask = mask;
      double e_pcss = compare_images(pcss, ref, o).mae, e_mv = compare_images(mv, ref, o).mae;
      const char* region = mask == &contact ? "contact" : "overlap";
      // The numbers docs/methods/pcss.md quotes.
      std::printf("[ numbers  ] pcss %-16s %-7s MAE %.3f (mean signed %+.3f); multi-view-sm MAE %.3f\n", variant, region,
                  e_pcss, compare_images(pcss, ref, o).mean_signed, e_mv);
      EXPECT_GT(e_pcss, 0.08) << variant << " " << region;
      EXPECT_GT(e_pcss, 5 * e_mv) << variant << " " << region;
      EXPECT_LT(e_mv, 0.02) << region;
    }
  }
  // Where the occluders overlap, PCSS's shadow is too light (the averaged blocker depth
  // lies between the two occluders and shrinks the nearer one's umbra).
  MetricOptions o;
  o.mask = &overlap;
  EXPECT_GT(compare_images(render_v(scene, "pcss"), ref, o).mean_signed, 0.05);
}

TEST(Pcss, Xie2007FilterSizeFollowsEquation1) {
  using shadow_map::xie2007_filter_size;
  // filter_size = resolution * light_radius * (1/z_min - 1/p.z)
  EXPECT_FLOAT_EQ(xie2007_filter_size(1000, 0.5f, 2.0f, 4.0f), 1000 * 0.5f * (0.5f - 0.25f));
  EXPECT_FLOAT_EQ(xie2007_filter_size(512, 1.0f, 1.0f, 2.0f), 256.0f);
  // Linear in the light radius and in the resolution; zero for the nearest surface and
  // in front of it; growing toward resolution * radius / z_min far away.
  EXPECT_FLOAT_EQ(xie2007_filter_size(512, 2.0f, 1.0f, 3.0f), 2 * xie2007_filter_size(512, 1.0f, 1.0f, 3.0f));
  EXPECT_FLOAT_EQ(xie2007_filter_size(1024, 1.0f, 1.0f, 3.0f), 2 * xie2007_filter_size(512, 1.0f, 1.0f, 3.0f));
  EXPECT_EQ(xie2007_filter_size(512, 1.0f, 2.0f, 2.0f), 0.0f);
  EXPECT_EQ(xie2007_filter_size(512, 1.0f, 2.0f, 1.5f), 0.0f);
  EXPECT_LT(xie2007_filter_size(512, 1.0f, 1.0f, 1e6f), 512.0f);
  EXPECT_NEAR(xie2007_filter_size(512, 1.0f, 1.0f, 1e6f), 512.0f, 1e-2f);
  // The paper's "resolution" is the focal length in texels: W / (2 tan(fov/2)), equal to
  // W for a window one unit wide at unit distance.
  LightView v = LightView::perspective({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 2 * degrees(std::atan(0.5f)), 640, 640, 0.1f, 10);
  EXPECT_NEAR(focal_texels(v), 640.0f, 1e-2f);
  // PCSS's penumbra width: (d_r - d_b) * light_size / d_b; as a filter radius in texels
  // (times focal / d_r) it is eq. 1 with z_min replaced by d_b.
  EXPECT_FLOAT_EQ(shadow_map::pcss_penumbra_width(0.5f, 1.0f, 3.0f), 1.0f);
  EXPECT_NEAR(shadow_map::pcss_penumbra_width(0.5f, 1.0f, 3.0f) * 640 / 3.0f, xie2007_filter_size(640, 0.5f, 1.0f, 3.0f),
              1e-3f);
  EXPECT_EQ(shadow_map::pcss_penumbra_width(0.5f, 3.0f, 2.0f), 0.0f);
}

TEST(Pcss, KernelOffsetIsWhereTheSegmentToTheLightPointCrossesTheBlockerPlane) {
  AreaLight light = rect_light_down({0.2f, 2, -0.1f}, 1.0f, 0.6f);
  std::vector<Vec3f> receivers = {{-1, 0, -1}, {1, 0, 1}, {0.3f, 0.2f, 0.1f}};
  LightView v = shadow_map::light_view_from(light, light.center, receivers, {}, 512, 120);
  const float f = focal_texels(v);
  const Vec3f p{0.3f, 0.2f, 0.1f};
  const Vec3f tp = v.to_texel(p);
  for (Vec2f u : {Vec2f(0.1f, 0.2f), Vec2f(0.9f, 0.5f), Vec2f(0.5f, 0.99f)}) {
    Vec3f q = light.sample_area(u);
    for (float zb : {0.5f, 1.0f, 1.6f}) {
      // The point of segment p -> q at linear depth zb.
      float a = (tp.z - zb) / (tp.z - v.linear_depth(q));
      Vec3f x = p + (q - p) * a;
      Vec3f tx = v.to_texel(x);
      Vec2f predicted = Vec2f(tp.x, tp.y) + shadow_map::kernel_offset(v, f, q) * (1.0f / zb - 1.0f / tp.z);
      EXPECT_NEAR(predicted.x, tx.x, 1e-2f);
      EXPECT_NEAR(predicted.y, tx.y, 1e-2f);
    }
  }
}

TEST(ShadowMap, FastLookupAgreesWithTheGeneralPath) {
  // ShadowDepthMap::lookup (hoisted per-map set-up) against receiver() + transmit_at().
  Scene scene = shipped("contact.json", 64);
  RayTracer tracer(scene);
  ViewSamples vs = camera_pass(scene, tracer, 0);
  const AreaLight& light = scene.lights[0];
  std::vector<Vec3f> receivers = shadow_map::receiver_points(vs, light);
  const RasterTriangles tris = gather_raster_triangles(scene);
  Rasterizer rasterizer;
  shadow_map::ShadowDepthMap sm;
  int shadowed = 0;
  for (Vec3f eye : {light.center, light.sample_area({0.1f, 0.9f})}) {
    sm.render(rasterizer, tris, shadow_map::light_view_from(light, eye, receivers, scene.bounds(), 256, 120));
    for (const char* mode : {"slope", "zero"}) {
      shadow_map::BiasParams b;
      if (std::string(mode) == "zero") b.bias = b.slope_bias = 0;
      for (const ViewSample& s : vs.samples) {
        shadow_map::Receiver r = sm.receiver(s.p, s.ng, b);
        for (bool closed : {false, true}) {
          float expected = !r.faces && closed ? 0.0f : sm.transmit_at(r, r.texel, b);
          ASSERT_EQ(sm.lookup(s.p, s.ng, closed, b), expected) << mode;
          shadowed += expected < 1;
        }
      }
    }
  }
  EXPECT_GT(shadowed, 1000);
  // The receiver plane's depth at a texel is where that texel's ray meets p's tangent
  // plane (clamped to at most p's own depth).
  shadow_map::BiasParams plane;
  plane.receiver_plane = true;
  plane.bias = 0;
  plane.max_slope = 1e6f;
  int checked = 0;
  for (size_t k = 0; k < vs.size(); k += 97) {
    const ViewSample& s = vs.samples[k];
    shadow_map::Receiver r = sm.receiver(s.p, s.ng, plane);
    if (!r.faces) continue;
    for (Vec2f d : {Vec2f(3, 0), Vec2f(-5, 7), Vec2f(20, -11)}) {
      int x = static_cast<int>(std::floor(r.texel.x + d.x)), y = static_cast<int>(std::floor(r.texel.y + d.y));
      LightView::TexelRay ray = sm.view().texel_ray({x + 0.5f, y + 0.5f});
      float t = dot(s.ng, s.p - ray.origin) / dot(s.ng, ray.dir);
      if (!(t > 0) || t > r.z) continue;
      EXPECT_NEAR(sm.reference_depth(r, x, y, plane), t, 1e-4f * t);
      ++checked;
    }
  }
  EXPECT_GT(checked, 20);
}

TEST(MultiViewShadowMap, ConvergesToTheReference) {
  Scene scene = small_scene(40);
  Image ref = render_v(scene, "reference", {}, 1024);
  double mae16 = compare_images(render_v(scene, "multi-view-sm", {}, 16), ref).mae;
  ErrorStats e256 = compare_images(render_v(scene, "multi-view-sm", {}, 256), ref);
  EXPECT_LT(e256.mae, 0.006);
  EXPECT_LT(mae16, 0.03);
  EXPECT_LT(e256.mae, 0.6 * mae16);
  // The contact shadow of the box does not leak: where the reference is dark, so is it.
  EXPECT_LT(e256.max_abs, 0.25);
}

TEST(MultiViewShadowMap, TheFarLookupIsTheLookupWithoutANearFieldAndIgnoresSurfacesInIt) {
  // mv_far_lookup (multi_view_shared.h): with no near field the plain lookup, bit for bit; with
  // one, a surface of p's texel blocks only if it lies beyond the near field toward the eye.
  Scene scene = small_scene(48);
  RayTracer tracer(scene);
  ViewSamples vs = camera_pass(scene, tracer, 0);
  const AreaLight& light = scene.lights[0];
  const std::vector<Vec3f> receivers = shadow_map::receiver_points(vs, light);
  Rasterizer rasterizer;
  shadow_map::ShadowDepthMap sm;
  sm.render(rasterizer, gather_raster_triangles(scene),
            shadow_map::light_view_from(light, light.center, receivers, scene.bounds(), 256, 120));
  const shader::ShadowMapView& m = sm.shared();
  int blocked = 0, beyond = 0, within = 0;
  for (bool plane : {false, true}) {
    shadow_map::BiasParams b;
    b.receiver_plane = plane;
    for (const ViewSample& s : vs.samples) {
      const bool closed = scene.objects[s.object].closed;
      const float hard = sm.lookup(s.p, s.ng, closed, b);
      ASSERT_EQ(shader::mv_far_lookup(sm.map().z.data(), sm.map().opacity.data(), m, s.p, s.ng, closed, b.shared(), 0),
                hard);
      if (hard != 0.0f || (closed && dot(s.ng, light.center - s.p) <= 0)) continue;
      ++blocked;
      // The surface the map holds: the first one the segment meets from the eye's end.
      const float seg = length(light.center - s.p);
      Ray ray{light.center, (s.p - light.center) / seg, 0, seg * (1 - 1e-3f)};
      Hit h;
      ASSERT_TRUE(tracer.intersect(ray, &h));
      const float d = seg - h.t;  // its distance from p
      // A near field that ends well before it: the map still answers blocked; one that ends well
      // past it: the surface is the near field's, and the map lets the light through.
      const auto far = [&](float near) {
        return shader::mv_far_lookup(sm.map().z.data(), sm.map().opacity.data(), m, s.p, s.ng, closed, b.shared(), near);
      };
      if (far(0.8f * d) == 0.0f) ++beyond;
      if (far(std::min(1.2f * d + 0.05f, seg)) == 1.0f) ++within;
    }
  }
  EXPECT_GT(blocked, 100);
  EXPECT_GE(beyond, 0.98 * blocked);  // texels at the occluders' edges may hold another surface
  EXPECT_GE(within, 0.98 * blocked);
  // The near field's length (near_field_shared.h): resolved = near_field texels at p's depth.
  const Vec3f p(0.1f, 0.0f, 0.2f);
  const float z = dot(p - m.view.eye, m.view.forward);
  const float texel = (m.view.r - m.view.l) / m.view.width * z / m.view.near;
  const float seg = length(m.view.eye - p);
  EXPECT_NEAR(shader::sm_near_field_length(m, p, 8, 1.0f), 8 * texel * seg / (1.0f + 8 * texel), 1e-5f * seg);
  EXPECT_EQ(shader::sm_near_field_length(m, p, 0, 1.0f), 0.0f);
  EXPECT_FLOAT_EQ(shader::sm_near_field_length(m, p, 8, 0.0f), seg);  // a point light: the whole ray
}

TEST(MultiViewShadowMap, TheNearFieldDrawsPenumbraeNarrowerThanTheTexels) {
  // Coarse maps (24 texels over the 4 m ground: 17 cm) under the square 0.5 above the ground and
  // the box standing on it: their penumbrae, 0.33 m and narrower at the box's foot, are a few
  // texels wide, and the 256 maps' average draws them as texel steps (every map's texels lie on the
  // same receivers). With the near field (32 texels) the rays are traced where it matters and the
  // error is the reference's own at these samples.
  Scene scene = small_scene(48);
  Image ref = render_v(scene, "reference", {}, 1024);
  RenderSettings settings;
  settings.method = "multi-view-sm";
  settings.light_samples = 256;
  settings.params = {"resolution=24", "near_field=0"};
  const RenderResult maps = render_scene(scene, settings);
  settings.params = {"resolution=24"};
  const RenderResult near = render_scene(scene, settings);
  const double mae_maps = compare_images(maps.visibility, ref).mae;
  const double mae_near = compare_images(near.visibility, ref).mae;
  const double mae_ref = compare_images(render_v(scene, "reference", {}, 256), ref).mae;
  std::printf("multi-view-sm 24-texel maps: mean |dV| %.4f alone, %.4f with the near field; reference %.4f\n",
              mae_maps, mae_near, mae_ref);
  EXPECT_LT(mae_near, 0.35 * mae_maps);
  EXPECT_LT(mae_near, 1.5 * mae_ref + 1e-3);
  EXPECT_EQ(maps.stats.extra["near_field_rays"], 0);
  EXPECT_GT(near.stats.extra["near_field_rays"].get<uint64_t>(), 48u * 48u);
}

TEST(MultiViewShadowMap, ReceiversBeyondAMapsWindowAreTraced) {
  // Maps 30 degrees wide (max_fov): most receivers lie outside most light points' maps, where a
  // map says nothing. They were lit there (a room lit through a window by a light just outside it
  // lost the walls' shadows so: mean |dV| 0.055 against the reference's own 0.019); now their
  // whole segment to that light point is traced (mv_traced_length), and the error is the
  // reference's own at these samples. The maps alone (near_field=0) keep the old answer.
  Scene scene = small_scene(40);
  Image ref = render_v(scene, "reference", {}, 1024);
  const double narrow = compare_images(render_v(scene, "multi-view-sm", {"max_fov=30"}, 256), ref).mae;
  const double alone = compare_images(render_v(scene, "multi-view-sm", {"max_fov=30", "near_field=0"}, 256), ref).mae;
  const double mae_ref = compare_images(render_v(scene, "reference", {}, 256), ref).mae;
  std::printf("multi-view-sm 30-degree maps: mean |dV| %.4f, maps alone %.4f; reference %.4f\n", narrow, alone, mae_ref);
  EXPECT_LT(narrow, 1.5 * mae_ref + 1e-3);
  EXPECT_GT(alone, 5 * narrow);
}

TEST(MultiViewShadowMap, DiskAndSphereLights) {
  // A disk light: its maps sample the disk itself. A sphere light: the maps sample the
  // disk through its centre facing the scene (AreaLight::sample_area), while `reference`
  // samples the cone each point sees: equal on the axis, an approximation off it.
  for (LightShape shape : {LightShape::Disk, LightShape::Sphere}) {
    Scene scene = small_scene(32);
    AreaLight& l = scene.lights[0];
    l.shape = shape;
    l.radius = 0.5f;
    scene.finalize();
    Image ref = render_v(scene, "reference", {}, 512);
    ErrorStats e = compare_images(render_v(scene, "multi-view-sm", {}, 256), ref);
    ErrorStats p = compare_images(render_v(scene, "pcss"), ref);
    EXPECT_LT(e.mae, shape == LightShape::Disk ? 0.004 : 0.01) << to_string(shape);
    EXPECT_LT(p.mae, 0.02) << to_string(shape);
  }
}

TEST(MultiViewShadowMap, SameImageForAnyThreadCountAndBoundedMemory) {
  Scene scene = small_scene(24);
  RenderSettings settings;
  settings.method = "multi-view-sm";
  settings.light_samples = 16;
  settings.seed = 4;
  RenderResult a, b;
  {
    ThreadLimit one(1);
    a = render_scene(scene, settings);
  }
  {
    ThreadLimit two(2);
    b = render_scene(scene, settings);
  }
  EXPECT_EQ(a.visibility.data(), b.visibility.data());
  // One map at a time: memory is one 512-texel map (16 bytes a texel), not 16 of them.
  EXPECT_LE(a.stats.memory_bytes, 512u * 512u * 16u);
  EXPECT_GT(a.stats.memory_bytes, 0u);
  EXPECT_EQ(a.stats.extra["maps"], 16);
  EXPECT_GT(a.stats.phase("raster"), 0.0);
  EXPECT_GT(a.stats.phase("lookup"), 0.0);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

// The memory-estimate checks (render/memory_estimate_test.cpp, testing/memory_cases.h): what
// each estimate must grow with, and a case whose maps dominate the heap.
const testing::MemoryCaseRegistration kShadowMapMemory(
    "shadow-map", {"resolution", "triangles"},
    {{"shadow-map", {"resolution=2048"}}});
const testing::MemoryCaseRegistration kPcssMemory(
    "pcss", {"resolution", "pcf_samples", "triangles"},
    {{"pcss", {"resolution=2048", "blocker_samples=4", "pcf_samples=4"}}});
const testing::MemoryCaseRegistration kMultiViewSmMemory(
    "multi-view-sm", {"resolution", "--spp", "triangles"},
    {{"multi-view-sm", {"resolution=1024"}, 2}});

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
