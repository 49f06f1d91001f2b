// The Python module (issue 16, docs/python.md): `import penumbra` gives scenes, the method
// registry, renders as NumPy arrays, and compare/sweep results as Python data. This file is
// the C++ extension `penumbra._penumbra`; src/python/penumbra/__init__.py is the package.
//
// Renders release the GIL and run on a thread of their own while the calling thread waits,
// taking the GIL back every 50 ms to let Python run its signal handlers: Ctrl-C cancels the
// render through a CancelToken (core/interrupt.h) and raises KeyboardInterrupt. penumbra's
// one-line errors become penumbra.Error, a ValueError.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <chrono>
#include <exception>
#include <future>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/core/image.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/core/parallel.h"
#include "penumbra/eval/comparison.h"
#include "penumbra/eval/reference_cache.h"
#include "penumbra/eval/run_setup.h"
#include "penumbra/eval/sweep.h"
#include "penumbra/render/renderer.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/scene/json_reader.h"
#include "penumbra/scene/scene.h"
#include "penumbra/shadow/shadow_method.h"

namespace py = pybind11;

namespace penumbra::python {
namespace {

// A scene and the document it came from (compare and sweep rewrite the document).
struct PyScene {
  Scene scene;
  nlohmann::json doc;
  std::filesystem::path path;  // the file, or a name for messages; relative mesh paths start at its folder
};

PyScene load(const std::string& path) {
  PyScene s;
  s.doc = read_json_file(path);
  s.scene = parse_scene(s.doc, path);
  s.path = path;
  return s;
}

PyScene from_json_text(const std::string& text, const std::string& base) {
  PyScene s;
  s.path = std::filesystem::path(base) / "<dict>";
  s.doc = parse_json_text(text, s.path.string());
  s.scene = parse_scene(s.doc, s.path);
  return s;
}

// Runs `work` on a thread of its own with the GIL released; the caller checks Python's
// signals every 50 ms and cancels the work on KeyboardInterrupt (which it then raises).
template <typename T>
T run_interruptible(const std::function<T()>& work) {
  CancelToken token;
  std::packaged_task<T()> task([&] {
    ScopedCancelToken scope(&token);
    return work();
  });
  std::future<T> result = task.get_future();
  std::thread thread(std::move(task));
  bool interrupted = false;
  {
    py::gil_scoped_release release;
    while (result.wait_for(std::chrono::milliseconds(50)) != std::future_status::ready) {
      py::gil_scoped_acquire acquire;
      if (PyErr_CheckSignals() != 0) {
        interrupted = true;
        token.cancel();
        break;
      }
    }
    thread.join();
  }
  if (interrupted) throw py::error_already_set();  // KeyboardInterrupt (the work was cancelled)
  return result.get();
}

py::array_t<float> to_array(const Image& image) {
  std::vector<py::ssize_t> shape = {image.height(), image.width()};
  if (image.channels() > 1) shape.push_back(image.channels());
  py::array_t<float> a(shape);
  std::copy(image.data().begin(), image.data().end(), a.mutable_data());
  return a;
}

py::object json_to_python(const nlohmann::json& j) {
  return py::module_::import("json").attr("loads")(j.dump());
}

nlohmann::json python_to_json(const py::handle& obj, const std::string& what) {
  try {
    return nlohmann::json::parse(py::module_::import("json").attr("dumps")(obj).cast<std::string>());
  } catch (const py::error_already_set& e) {
    throw py::type_error(what + ": not JSON-serialisable (" + std::string(e.what()) + ")");
  }
}

struct PyRenderResult {
  py::array_t<float> color, visibility;
  py::object stats;
};

// A render's scene and settings from render()'s arguments, checked as the command line does.
struct RenderRequest {
  Scene scene;
  RenderSettings settings;
};

RenderRequest render_request(const PyScene& s, const std::string& method, int spp,
                             std::optional<std::pair<int, int>> resolution, uint64_t seed,
                             const std::optional<py::dict>& params, int threads, int frames,
                             std::optional<std::tuple<int, int, int, int>> crop, const std::string& device) {
  MethodRegistry::get(method);  // throws, listing the registered methods, for an unknown one
  const gpu::DeviceChoice choice = gpu::DeviceChoice::parse(device);  // "device=...": `--device`'s values
  if (spp < 1 || spp > (1 << 20)) throw Error("spp={}: expected an integer in [1, 1048576]", spp);
  if (frames < 1 || frames > 100000) throw Error("frames={}: expected an integer in [1, 100000]", frames);
  if (threads < 0) throw Error("threads={}: expected 0 (all cores) or more", threads);
  RenderRequest q{s.scene, {}};
  if (resolution) {
    if (resolution->first < 1 || resolution->second < 1 || resolution->first > 16384 || resolution->second > 16384)
      throw Error("resolution=({}, {}): expected two integers in [1, 16384]", resolution->first, resolution->second);
    q.scene.camera.width = resolution->first;
    q.scene.camera.height = resolution->second;
  }
  // `penumbra render`'s settings for the same arguments (app/cmd_render.cpp).
  RenderSettings& settings = q.settings;
  settings.method = method;
  settings.light_samples = spp;
  settings.seed = seed;
  settings.frames = frames;
  settings.device = choice;
  if (crop) {
    const auto [x0, y0, x1, y1] = *crop;
    settings.crop = PixelWindow{x0, y0, x1, y1};
    if (x0 >= x1 || y0 >= y1 || !settings.crop.inside(q.scene.camera.width, q.scene.camera.height))
      throw Error("crop=({}, {}, {}, {}): expected x0 < x1 and y0 < y1 inside the {}x{} image", x0, y0, x1, y1,
                  q.scene.camera.width, q.scene.camera.height);
  }
  if (params)
    for (const auto& [key, value] : *params) {
      const std::string k = py::str(key);
      const nlohmann::json v = python_to_json(value, "params[" + k + "]");
      settings.params.push_back(k + "=" + (v.is_string() ? v.get<std::string>() : v.dump()));
    }
  return q;
}

PyRenderResult to_python(const RenderRequest& q, const RenderResult& r) {
  nlohmann::json stats = render_stats_json(q.scene, q.settings.method, q.settings, r);
  return {to_array(r.color), to_array(r.visibility), json_to_python(stats)};
}

PyRenderResult render(const PyScene& s, const std::string& method, int spp, std::optional<std::pair<int, int>> resolution,
                      uint64_t seed, const std::optional<py::dict>& params, int threads, int frames,
                      std::optional<std::tuple<int, int, int, int>> crop, const std::string& map_cache,
                      const std::string& device) {
  RenderRequest q = render_request(s, method, spp, resolution, seed, params, threads, frames, crop, device);
  q.settings.map_cache = map_cache;
  RenderResult r = run_interruptible<RenderResult>([&] {
    ThreadLimit limit(threads);
    return render_scene(q.scene, q.settings);
  });
  return to_python(q, r);
}

// Windows of one frame rendered one after another by one Renderer, which keeps the Embree
// scene and the method's light-space structures between them: a worker of
// penumbra.distributed pays for them once, not once per tile. Each window's pixels are
// render(..., crop=window)'s.
class PyFrameRenderer {
 public:
  PyFrameRenderer(const PyScene& s, const std::string& method, int spp, uint64_t seed,
                  const std::optional<py::dict>& params, int threads, int frames, const std::string& device)
      : request_(render_request(s, method, spp, std::nullopt, seed, params, threads, frames, std::nullopt, device)),
        threads_(threads) {}

  PyRenderResult render(std::tuple<int, int, int, int> crop) {
    const auto [x0, y0, x1, y1] = crop;
    RenderRequest q = request_;
    q.settings.crop = PixelWindow{x0, y0, x1, y1};
    if (x0 >= x1 || y0 >= y1 || !q.settings.crop.inside(q.scene.camera.width, q.scene.camera.height))
      throw Error("crop=({}, {}, {}, {}): expected x0 < x1 and y0 < y1 inside the {}x{} image", x0, y0, x1, y1,
                  q.scene.camera.width, q.scene.camera.height);
    RenderResult r = run_interruptible<RenderResult>([&] {
      ThreadLimit limit(threads_);
      if (!renderer_) renderer_ = std::make_unique<Renderer>(q.scene, q.settings);
      renderer_->set_crop(q.settings.crop);
      return renderer_->render();
    });
    return to_python(q, r);
  }

 private:
  RenderRequest request_;
  int threads_ = 0;
  std::unique_ptr<Renderer> renderer_;
};

RunSetup run_setup(const PyScene& s, int spp, int reference_spp, uint64_t seed, const std::vector<std::string>& settings,
                   const std::string& device = "cpu") {
  RunSetup setup;
  setup.device = gpu::DeviceChoice::parse(device).to_string();
  setup.scene_doc = s.doc;
  setup.scene_path = s.path;
  setup.light_samples = spp;
  setup.reference_samples = reference_spp;
  setup.seed = seed;
  for (const std::string& kv : settings) setup.apply(kv);
  return setup;
}

// --- The steps penumbra.distributed runs as jobs (docs/distributed.md). Everything that
// crosses between the client and the workers is plain Python data: JSON text and NumPy
// arrays, which Dask pickles cheaply; no C++ object is pickled.

Image from_array(const py::array_t<float, py::array::c_style | py::array::forcecast>& a, const std::string& what) {
  if (a.ndim() != 2 && a.ndim() != 3) throw Error("{}: expected an H x W or H x W x C array", what);
  const int h = static_cast<int>(a.shape(0)), w = static_cast<int>(a.shape(1));
  const int c = a.ndim() == 3 ? static_cast<int>(a.shape(2)) : 1;
  Image image(w, h, c, 0.0f);
  std::copy(a.data(), a.data() + static_cast<size_t>(w) * h * c, image.data().begin());
  return image;
}

RunSetup setup_from_text(const std::string& text) { return run_setup_from_json(parse_json_text(text, "run setup")); }

// A ground truth as (JSON text, colour, V), and back.
py::tuple truth_to_python(const GroundTruth& t) {
  return py::make_tuple(ground_truth_json(t).dump(), to_array(t.color), to_array(t.visibility));
}
GroundTruth truth_from_python(const py::tuple& t) {
  if (t.size() != 3) throw Error("ground truth: expected (json, color, visibility)");
  GroundTruth truth = ground_truth_from_json(nlohmann::json::parse(t[0].cast<std::string>()));
  truth.color = from_array(t[1].cast<py::array_t<float, py::array::c_style | py::array::forcecast>>(), "truth color");
  truth.visibility =
      from_array(t[2].cast<py::array_t<float, py::array::c_style | py::array::forcecast>>(), "truth visibility");
  return truth;
}

CompareOptions compare_options(int runs, int warmup_runs, bool equal_quality, const std::string& cache_dir) {
  CompareOptions o;
  o.runs = runs;
  o.warmup_runs = warmup_runs;
  o.equal_quality = equal_quality;
  o.cache_dir = cache_dir;
  return o;
}

}  // namespace
}  // namespace penumbra::python

PYBIND11_MODULE(_penumbra, m) {
  using namespace penumbra;
  using namespace penumbra::python;
  m.doc() = "penumbra: soft shadows from area lights (docs/python.md)";
  // penumbra.Error, a ValueError: what the command line prints as its one-line error.
  py::register_exception<Error>(m, "Error", PyExc_ValueError);

  py::class_<PyScene>(m, "Scene", "A scene: camera, area lights and meshes (docs/scene-format.md)")
      .def_static("_from_json", &from_json_text, py::arg("text"), py::arg("base_path"))
      .def_property_readonly("resolution", [](const PyScene& s) { return std::make_pair(s.scene.camera.width, s.scene.camera.height); })
      .def_property_readonly("triangles", [](const PyScene& s) { return s.scene.triangle_count(); })
      .def_property_readonly("lights", [](const PyScene& s) { return s.scene.lights.size(); })
      .def_property_readonly("path", [](const PyScene& s) { return s.path.string(); })
      .def("_document", [](const PyScene& s) { return s.doc.dump(); })
      .def("__repr__", [](const PyScene& s) {
        return "<penumbra.Scene " + s.path.string() + ": " + std::to_string(s.scene.triangle_count()) + " triangles, " +
               std::to_string(s.scene.lights.size()) + " light(s), " + std::to_string(s.scene.camera.width) + "x" +
               std::to_string(s.scene.camera.height) + ">";
      });

  py::class_<PyRenderResult>(m, "RenderResult", "A rendered frame: colour, visibility and statistics")
      .def_readonly("color", &PyRenderResult::color, "H x W x 3 float32, linear RGB radiance")
      .def_readonly("visibility", &PyRenderResult::visibility, "H x W float32: V, the fraction of the light seen")
      .def_readonly("stats", &PyRenderResult::stats, "the --stats-json document");

  py::class_<PyFrameRenderer>(m, "_FrameRenderer")
      .def(py::init<const PyScene&, const std::string&, int, uint64_t, const std::optional<py::dict>&, int, int,
                    const std::string&>(),
           py::arg("scene"), py::arg("method"), py::arg("spp"), py::arg("seed"), py::arg("params"), py::arg("threads"),
           py::arg("frames"), py::arg("device") = "cpu")
      .def("render", &PyFrameRenderer::render, py::arg("crop"));

  m.def("load_scene", &load, py::arg("path"), "Loads and validates a scene file.");
  m.def("methods", [] {
    std::vector<std::string> names;
    for (const MethodInfo* info : MethodRegistry::all()) names.push_back(info->name);
    return names;
  }, "The registered shadow methods' names.");
  m.def("method_params", [](const std::string& name) {
    const MethodInfo& info = MethodRegistry::get(name);
    nlohmann::json out = nlohmann::json::array();
    for (const ParamSpec& p : info.params)
      out.push_back({{"name", p.name}, {"type", to_string(p.type)}, {"default", p.default_value}, {"doc", p.doc},
                     {"choices", p.choices},
                     {"min", p.min > -1e299 ? nlohmann::json(p.min) : nlohmann::json(nullptr)},
                     {"max", p.max < 1e299 ? nlohmann::json(p.max) : nlohmann::json(nullptr)}});
    return json_to_python(out);
  }, py::arg("name"), "A method's parameter table: name, type, default, doc, choices, min, max.");
  m.def("render", &render, py::arg("scene"), py::arg("method") = "reference", py::arg("spp") = 256,
        py::arg("resolution") = py::none(), py::arg("seed") = 0, py::arg("params") = py::none(),
        py::arg("threads") = 0, py::arg("frames") = 1, py::arg("crop") = py::none(), py::arg("map_cache") = "",
        py::arg("device") = "cpu",
        "Renders `scene` with `method`: the pixels `penumbra render` writes for the same arguments. "
        "device='gpu' (or 'gpu:N'): the whole frame on a Vulkan GPU, as `--device gpu` (docs/gpu.md). "
        "crop=(x0, y0, x1, y1): only those pixels (half-open), the images that window's size, each "
        "pixel equal to the whole frame's there. map_cache=folder: `--map-cache` (light-space maps kept "
        "on disk between runs; stats['map_cache'] says hits and sizes).");
  m.def("_compare", [](const PyScene& s, const std::vector<std::string>& methods, int spp, int reference_spp,
                       uint64_t seed, const std::vector<std::string>& settings, int runs, bool equal_quality,
                       const std::string& cache_dir, const std::string& device, const std::vector<std::string>& objects) {
    RunSetup setup = run_setup(s, spp, reference_spp, seed, settings, device);
    CompareOptions options;
    options.methods = expand_method_list(methods);
    options.runs = runs;
    options.equal_quality = equal_quality;
    options.cache_dir = cache_dir;
    options.keep_images = false;
    options.objects = objects;
    Comparison c = run_interruptible<Comparison>([&] { return run_comparison(setup, options); });
    return comparison_json(c).dump();
  });
  m.def("_sweep", [](const PyScene& s, const std::string& key, const std::vector<std::string>& values,
                     const std::vector<std::string>& methods, int spp, int reference_spp, uint64_t seed,
                     const std::vector<std::string>& settings, int runs, const std::string& cache_dir,
                     const std::string& device) {
    RunSetup setup = run_setup(s, spp, reference_spp, seed, settings, device);
    SweepOptions options;
    options.key = key;
    options.values = values;
    options.methods = expand_method_list(methods);
    options.runs = runs;
    options.cache_dir = cache_dir;
    Sweep sweep = run_interruptible<Sweep>([&] { return run_sweep(setup, options); });
    return sweep_json(sweep).dump();
  });
  // --- penumbra.distributed's jobs. A run setup is the JSON text of run_setup_json().
  m.def("_run_setup", [](const PyScene& s, int spp, int reference_spp, uint64_t seed,
                         const std::vector<std::string>& settings, const std::string& device) {
    return run_setup_json(run_setup(s, spp, reference_spp, seed, settings, device)).dump();
  }, py::arg("scene"), py::arg("spp"), py::arg("reference_spp"), py::arg("seed"), py::arg("settings"),
     py::arg("device") = "cpu");
  m.def("devices", [] {
    nlohmann::json out = nlohmann::json::array();
    for (const gpu::DeviceInfo& d : gpu::list_devices())
      out.push_back({{"device", fmt::format("gpu:{}", d.index)}, {"name", d.name}, {"type", d.type},
                     {"driver", d.driver}, {"vulkan", d.api_version}, {"memory_bytes", d.memory_bytes},
                     {"subgroup_size", d.subgroup_size}, {"usable", d.usable}, {"unusable_reason", d.unusable_reason}});
    return json_to_python(out);
  }, "The Vulkan devices device='gpu:N' can name (`penumbra devices --json`): a list of dicts. Raises "
     "penumbra.Error when this machine has no Vulkan loader.");
  m.def("method_devices", [](const std::string& name) {
    MethodRegistry::get(name);
    std::vector<std::string> d = {"cpu"};
    if (find_gpu_method(name)) d.push_back("gpu");
    return d;
  }, py::arg("name"), "The devices a method runs on: ['cpu'] or ['cpu', 'gpu'] (`penumbra methods`).");
  m.def("_tile_exact", [](const std::string& name) { return MethodRegistry::get(name).tile_exact; });
  // The device a compare job of `label` renders on: its spec's (NAME@gpu) or the setup's.
  m.def("_method_device", [](const std::string& setup_text, const std::string& label) {
    const MethodSpec spec = parse_method_spec(label);
    return spec.device.empty() ? setup_from_text(setup_text).device : spec.device;
  });
  m.def("_expand_methods", [](const std::vector<std::string>& names) { return expand_method_list(names); });
  m.def("_check_methods", [](const std::string& setup, const std::vector<std::string>& methods) {
    setup_from_text(setup).check_plain_params(methods);
  });
  m.def("_sweep_setups", [](const std::string& base, const std::string& key, const std::vector<std::string>& values,
                            const std::vector<std::string>& methods) {
    SweepOptions o;
    o.key = key;
    o.values = values;
    o.methods = methods;
    sweep_header(setup_from_text(base), o);  // the same checks as run_sweep
    std::vector<std::string> out;
    for (const RunSetup& setup : sweep_setups(setup_from_text(base), o)) out.push_back(run_setup_json(setup).dump());
    return out;
  });
  m.def("_scene_of_setup", [](const std::string& setup) {
    const RunSetup r = setup_from_text(setup);
    PyScene s;
    s.doc = r.scene_doc;
    s.path = r.scene_path;
    s.scene = r.load();
    return s;
  });
  // The jobs take the setup's scene loaded (_scene_of_setup), so a worker loads it once.
  // `timed`: the speed-ups will divide its time (no `reference` among the methods), so a time
  // from the cache that another machine or thread count measured is measured again here.
  m.def("_ground_truth", [](const std::string& setup_text, const PyScene& scene, const std::string& cache_dir,
                            int threads, bool timed) {
    const RunSetup setup = setup_from_text(setup_text);
    GroundTruth t = run_interruptible<GroundTruth>([&] {
      ThreadLimit limit(threads);
      GroundTruth truth = ground_truth(setup, scene.scene, cache_dir);
      if (timed) time_ground_truth(truth, setup, scene.scene, cache_dir);
      return truth;
    });
    return truth_to_python(t);
  });
  // A method's renders without error columns (the ground truth may still be rendering
  // elsewhere; _measure_method adds them): (entry, colour or None, V or None).
  m.def("_compare_method", [](const std::string& setup_text, const PyScene& scene, const std::string& label,
                              int runs, int warmup_runs, bool keep_images, int threads) {
    const RunSetup setup = setup_from_text(setup_text);
    CompareOptions options = compare_options(runs, warmup_runs, false, "");
    options.keep_images = keep_images;
    MethodRun r = run_interruptible<MethodRun>([&] {
      ThreadLimit limit(threads);
      return compare_method(setup, scene.scene, label, nullptr, options);
    });
    py::object color = py::none(), vis = py::none();
    if (!r.color.empty()) color = to_array(r.color);
    if (!r.visibility.empty()) vis = to_array(r.visibility);
    return py::make_tuple(method_run_json(r).dump(), color, vis);
  });
  // A method's entry, rendered without the ground truth, measured against it: (entry, colour
  // or None, V or None) as _compare_method gives, the images kept when asked.
  m.def("_measure_method", [](const std::string& entry, const py::object& color, const py::object& visibility,
                              const py::tuple& truth, bool keep_images) {
    MethodRun r = method_run_from_json(nlohmann::json::parse(entry));
    if (!r.ok) return py::make_tuple(entry, py::none(), py::none());
    using Array = py::array_t<float, py::array::c_style | py::array::forcecast>;
    const Image c = from_array(color.cast<Array>(), "color"), v = from_array(visibility.cast<Array>(), "visibility");
    const GroundTruth t = truth_from_python(truth);
    {
      py::gil_scoped_release release;
      measure_against_truth(r, c, v, t);
    }
    if (!keep_images) return py::make_tuple(method_run_json(r).dump(), py::none(), py::none());
    return py::make_tuple(method_run_json(r).dump(), color, visibility);
  });
  // The reference ladder for the methods' entries (JSON texts), or None.
  m.def("_comparison_ladder", [](const std::string& setup_text, const PyScene& scene, const py::tuple& truth,
                                 const std::vector<std::string>& runs, int timed_runs, int warmup_runs,
                                 const std::string& cache_dir, int threads) -> py::object {
    const RunSetup setup = setup_from_text(setup_text);
    Comparison c;
    c.truth = truth_from_python(truth);
    c.has_ground_truth = true;
    for (const std::string& r : runs) c.runs.push_back(method_run_from_json(nlohmann::json::parse(r)));
    const CompareOptions options = compare_options(timed_runs, warmup_runs, true, cache_dir);
    std::optional<ReferenceLadder> ladder = run_interruptible<std::optional<ReferenceLadder>>([&] {
      ThreadLimit limit(threads);
      return comparison_ladder(c, setup, scene.scene, options);
    });
    if (!ladder) return py::none();
    return py::str(reference_ladder_json(*ladder).dump());
  });
  // results.json from the parts: the header of the setup, the ground truth's entry (or
  // None), the methods' entries in order, the ladder (or None); speed-ups as run_comparison.
  m.def("_assemble_comparison", [](const std::string& setup_text, const py::object& truth,
                                   const std::vector<std::string>& runs, const py::object& ladder, double wall_ms,
                                   const std::string& command) {
    const RunSetup setup = setup_from_text(setup_text);
    Comparison c = comparison_header(setup, setup.load());
    if (!truth.is_none()) {
      c.truth = ground_truth_from_json(nlohmann::json::parse(truth.cast<std::string>()));
      c.has_ground_truth = true;
    }
    for (const std::string& r : runs) c.runs.push_back(method_run_from_json(nlohmann::json::parse(r)));
    if (!ladder.is_none()) apply_ladder(c, reference_ladder_from_json(nlohmann::json::parse(ladder.cast<std::string>())));
    apply_speedups(c);
    c.wall_ms = wall_ms;
    c.command = command;
    return comparison_json(c).dump();
  });
  // Writes `penumbra compare`'s report (DIR/index.html, results.json, results.csv, images/)
  // from results.json and the images: truth (colour, V) or None; method label -> (colour, V).
  m.def("_write_comparison", [](const std::string& results, const py::object& truth_images, const py::dict& images,
                                const std::string& dir, float heatmap_scale, bool write_images) {
    Comparison c = comparison_from_json(nlohmann::json::parse(results));
    using Array = py::array_t<float, py::array::c_style | py::array::forcecast>;
    if (!truth_images.is_none()) {
      const py::tuple t = truth_images.cast<py::tuple>();
      c.truth.color = from_array(t[0].cast<Array>(), "truth color");
      c.truth.visibility = from_array(t[1].cast<Array>(), "truth visibility");
    }
    for (MethodRun& r : c.runs) {
      if (!images.contains(r.method)) continue;
      const py::tuple t = images[py::str(r.method)].cast<py::tuple>();
      r.color = from_array(t[0].cast<Array>(), r.method + " color");
      r.visibility = from_array(t[1].cast<Array>(), r.method + " visibility");
    }
    ReportOptions ro;
    ro.heatmap_scale = heatmap_scale;
    ro.write_images = write_images;
    py::gil_scoped_release release;
    write_comparison(c, dir, ro);
  });
  // sweep.json from each value's results.json (in the order of the values); with pages_dir,
  // also each value's comparison page (pages: value index -> images as for _write_comparison).
  m.def("_assemble_sweep", [](const std::string& base, const std::string& key, const std::vector<std::string>& values,
                              const std::vector<std::string>& methods, bool ground_truth,
                              const std::vector<std::string>& comparisons, double wall_ms, const std::string& command,
                              const std::string& out_dir, const std::vector<std::string>& plots,
                              const std::string& x_scale, const std::string& y_scale) {
    SweepOptions o;
    o.key = key;
    o.values = values;
    o.methods = methods;
    o.ground_truth = ground_truth;
    Sweep s = sweep_header(setup_from_text(base), o);
    if (comparisons.size() != values.size()) throw Error("sweep: {} comparisons for {} values", comparisons.size(), values.size());
    for (size_t i = 0; i < values.size(); ++i)
      add_sweep_value(s, i, comparison_from_json(nlohmann::json::parse(comparisons[i])), o);
    s.wall_ms = wall_ms;
    s.command = command;
    if (!out_dir.empty()) {
      auto axis = [](const std::string& a) {
        return a == "log" ? AxisScale::kLog : a == "linear" ? AxisScale::kLinear : AxisScale::kAuto;
      };
      SweepPlotOptions po;
      po.x_scale = axis(x_scale);
      po.y_scale = axis(y_scale);
      po.extra_plots = plots;
      write_sweep(s, out_dir, po);
    }
    return sweep_json(s).dump();
  });
  // An EXR of the frame (colour with a V channel) for the command line's `render --dask`,
  // which reads it back and writes its outputs as a local render would (float32: lossless).
  m.def("_write_frame", [](const std::string& path, const py::array_t<float, py::array::c_style | py::array::forcecast>& color,
                           const py::array_t<float, py::array::c_style | py::array::forcecast>& visibility) {
    const Image c = from_array(color, "color"), v = from_array(visibility, "visibility");
    write_image(path, c, {{"V", &v}});
  });
  m.def("read_exr", [](const std::string& path, const std::string& channel) {
    return to_array(channel.empty() ? read_image(path) : read_exr_channel(path, channel));
  }, py::arg("path"), py::arg("channel") = "", "Reads an image (EXR, PNG) or one EXR channel as float32.");
}
