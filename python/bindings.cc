// The Python module hapvox._hapvox (python/hapvox/__init__.py re-exports it): the public C++
// API (include/hapvox/) with numpy arrays for its vectors. Long calls release the GIL; a
// Python device callback takes it back for each tick.

#include <hapvox/hapvox.h>
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstring>

namespace py = pybind11;
using hapvox::InputError;

namespace {

using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;

py::array_t<double> to_numpy(const std::vector<double>& values, std::vector<std::size_t> shape) {
  std::vector<py::ssize_t> dims(shape.begin(), shape.end());
  py::array_t<double> out(dims);
  if (!values.empty())
    std::memcpy(out.mutable_data(), values.data(), values.size() * sizeof(double));
  return out;
}

py::array_t<double> vec3(const std::array<double, 3>& v) {
  return to_numpy({v[0], v[1], v[2]}, {3});
}

std::array<double, 3> as_vec3(const py::handle& value, const char* what) {
  const Array a = Array::ensure(value);
  if (!a || a.size() != 3) throw InputError(what, "expected 3 numbers");
  return {a.data()[0], a.data()[1], a.data()[2]};
}

hapvox::DeviceTransform transform_of(double scale, const py::object& rotate_deg,
                                     const py::object& offset_mm) {
  hapvox::DeviceTransform t;
  t.scale = scale;
  t.rotate_deg = as_vec3(rotate_deg, "rotate_deg");
  t.offset_mm = as_vec3(offset_mm, "offset_mm");
  return t;
}

hapvox::ModelOptions model_options(const std::string& model,
                                   std::optional<double> youngs_modulus_pa,
                                   std::optional<double> poisson_ratio,
                                   std::optional<double> tool_diameter_mm,
                                   const std::string& contact_law, bool plastic,
                                   std::optional<double> yield_stress_pa,
                                   const std::string& materials, const std::string& labels,
                                   const std::vector<std::string>& flags) {
  hapvox::ModelOptions o;
  o.model = model;
  o.youngs_modulus_pa = youngs_modulus_pa;
  o.poisson_ratio = poisson_ratio;
  o.tool_diameter_mm = tool_diameter_mm;
  o.contact_law = contact_law;
  o.plastic = plastic;
  o.yield_stress_pa = yield_stress_pa;
  o.materials = materials;
  o.labels = labels;
  o.flags = flags;
  return o;
}

hapvox::IntensityOptions intensity_options(std::optional<double> threshold,
                                           std::optional<std::array<double, 2>> window) {
  hapvox::IntensityOptions o;
  o.threshold = threshold;
  o.window = window;
  return o;
}

hapvox::LoopOptions loop_options(double max_force_n, double ramp_in_s,
                                 const std::string& session_path) {
  hapvox::LoopOptions o;
  o.max_force_n = max_force_n;
  o.ramp_in_s = ramp_in_s;
  o.session_path = session_path;
  return o;
}

py::object dataset_array(const hapvox::Session& s, const std::string& name) {
  const hapvox::Dataset& d = s.dataset(name);
  return to_numpy(d.values, d.shape);
}

/// "KeyError: 'no sample'": a Python exception's type and message, without its traceback.
std::string python_error_text(py::error_already_set& e) {
  return py::str(e.type().attr("__name__")).cast<std::string>() + ": " +
         py::str(e.value()).cast<std::string>();
}

/// The first exception a Python device callback raised during a run (the loop cannot unwind).
struct CallbackError {
  std::string message;
  std::array<double, 3> last_position_mm = {0.0, 0.0, 0.0};
  void keep(const char* which, std::size_t tick, const std::string& what) {
    if (message.empty()) {
      message = std::string("device callback ") + which + " raised at tick " +
                std::to_string(tick) + ": " + what;
    }
  }
};

/// hapvox::Device with what its Python callbacks raised (none for a trace).
struct PythonDevice {
  hapvox::Device device;
  std::shared_ptr<CallbackError> error;
};

/// Runs `run(device)` without the GIL, then raises what a callback raised during it.
template <typename Run>
hapvox::RunSummary run_device(PythonDevice& d, Run run) {
  if (d.error) d.error->message.clear();
  hapvox::RunSummary summary;
  {
    py::gil_scoped_release release;
    summary = run(d.device);
  }
  if (d.error && !d.error->message.empty()) throw std::runtime_error(d.error->message);
  return summary;
}

py::dict tick_dict(const hapvox::ForceTick& t) {
  py::dict d;
  d["force_n"] = vec3(t.force_n);
  d["force_device_n"] = vec3(t.force_device_n);
  d["tool_position_mm"] = vec3(t.tool_position_mm);
  d["displacement_mm"] = vec3(t.displacement_mm);
  d["force_scale"] = t.force_scale;
  d["contact_area_mm2"] = t.contact_area_mm2;
  d["contact"] = t.contact;
  d["clamped"] = t.clamped;
  d["fault"] = t.fault;
  return d;
}

}  // namespace

PYBIND11_MODULE(_hapvox, m) {
  m.doc() = "hapvox: haptic forces on 3D images (the public C++ API, docs/api.md)";
  m.attr("__version__") = hapvox::version();
  // The message is the line `hapvox` prints after "hapvox: error: " for the same input.
  py::register_exception<InputError>(m, "InputError", PyExc_ValueError);

  py::class_<hapvox::Volume>(m, "Volume", "A density field in [0, 1] (docs/api.md)")
      .def_static(
          "load",
          [](const std::string& spec, std::optional<double> threshold,
             std::optional<std::array<double, 2>> window) {
            const hapvox::IntensityOptions o = intensity_options(threshold, window);
            py::gil_scoped_release release;
            return hapvox::Volume::load(spec, o);
          },
          py::arg("spec"), py::arg("threshold") = py::none(), py::arg("window") = py::none(),
          "A volume file, a DICOM folder or a generator, as --volume takes it")
      .def_static(
          "from_array",
          [](const py::array_t<float, py::array::f_style | py::array::forcecast>& density,
             const py::object& spacing_mm, const py::object& origin_mm) {
            if (density.ndim() != 3) throw InputError("array", "expected a 3-D array [i, j, k]");
            const std::array<int, 3> dims = {static_cast<int>(density.shape(0)),
                                             static_cast<int>(density.shape(1)),
                                             static_cast<int>(density.shape(2))};
            std::vector<float> values(density.data(), density.data() + density.size());
            return hapvox::Volume::from_densities(values, dims, as_vec3(spacing_mm, "spacing_mm"),
                                                  as_vec3(origin_mm, "origin_mm"));
          },
          py::arg("density"), py::arg("spacing_mm") = std::array<double, 3>{1.0, 1.0, 1.0},
          py::arg("origin_mm") = std::array<double, 3>{0.0, 0.0, 0.0},
          "Densities in [0, 1] indexed [i, j, k] (x, y, z), voxel (i, j, k) centred at "
          "origin_mm + (i, j, k) * spacing_mm")
      .def(
          "to_array",
          [](const hapvox::Volume& v) {
            const auto d = v.dims();
            const std::vector<float> values = v.densities();
            py::array_t<float, py::array::f_style> out({d[0], d[1], d[2]});
            std::memcpy(out.mutable_data(), values.data(), values.size() * sizeof(float));
            return out;
          },
          "The densities, indexed [i, j, k]")
      .def_property_readonly("dims", &hapvox::Volume::dims)
      .def_property_readonly("spacing_mm", &hapvox::Volume::spacing_mm)
      .def_property_readonly("origin_mm", &hapvox::Volume::origin_mm)
      .def_property_readonly("world_min_mm", &hapvox::Volume::world_min_mm)
      .def_property_readonly("world_max_mm", &hapvox::Volume::world_max_mm)
      .def_property_readonly("source", &hapvox::Volume::source)
      .def("save", &hapvox::Volume::save, py::arg("path"), "Writes .nrrd or .vdb");

  py::class_<hapvox::Trace>(m, "Trace", "Tool positions over time, device frame (s, mm)")
      .def_static(
          "load",
          [](const std::string& path, const std::string& time_col,
             const std::array<std::string, 3>& pos_cols, const std::string& time_unit,
             const std::string& pos_unit) {
            hapvox::TraceColumns c;
            c.time = time_col;
            c.position = pos_cols;
            c.time_unit = time_unit;
            c.position_unit = pos_unit;
            return hapvox::Trace::load(path, c);
          },
          py::arg("path"), py::arg("time_col") = "t",
          py::arg("pos_cols") = std::array<std::string, 3>{"x", "y", "z"},
          py::arg("time_unit") = "s", py::arg("pos_unit") = "mm")
      .def_static(
          "from_arrays",
          [](const Array& time_s, const Array& position_mm) {
            if (time_s.ndim() != 1) throw InputError("trace", "time_s must be 1-D");
            if (position_mm.ndim() != 2 || position_mm.shape(1) != 3) {
              throw InputError("trace", "position_mm must have shape (N, 3)");
            }
            std::vector<double> t(time_s.data(), time_s.data() + time_s.size());
            std::vector<std::array<double, 3>> p(static_cast<std::size_t>(position_mm.shape(0)));
            std::memcpy(p.data(), position_mm.data(), p.size() * sizeof(p[0]));
            return hapvox::Trace::from_samples(t, p);
          },
          py::arg("time_s"), py::arg("position_mm"))
      .def_property_readonly(
          "time_s", [](const hapvox::Trace& t) { return to_numpy(t.time_s(), {t.size()}); })
      .def_property_readonly("position_mm",
                             [](const hapvox::Trace& t) {
                               std::vector<double> flat;
                               for (const auto& p : t.position_mm())
                                 flat.insert(flat.end(), p.begin(), p.end());
                               return to_numpy(flat, {t.size(), 3});
                             })
      .def("__len__", &hapvox::Trace::size)
      .def(
          "resampled",
          [](const hapvox::Trace& t, double rate_hz, double max_gap_s) {
            const std::vector<hapvox::ToolSample> ticks = t.resampled(rate_hz, max_gap_s);
            std::vector<double> time, pos, holding;
            for (const auto& s : ticks) {
              time.push_back(s.time_s);
              pos.insert(pos.end(), s.position_mm.begin(), s.position_mm.end());
              holding.push_back(s.holding ? 1.0 : 0.0);
            }
            return py::make_tuple(to_numpy(time, {ticks.size()}), to_numpy(pos, {ticks.size(), 3}),
                                  to_numpy(holding, {ticks.size()}).attr("astype")("bool"));
          },
          py::arg("rate_hz") = 1000.0, py::arg("max_gap_s") = 0.05,
          "(time_s, position_mm, holding) on the loop's clock, as a replay reads it")
      .def("save", &hapvox::Trace::save, py::arg("path"));

  py::class_<hapvox::Model>(m, "Model", "A deformation model bound to a volume (constant)")
      .def_static(
          "voxel",
          [](const hapvox::Volume& volume, std::optional<double> youngs_modulus_pa,
             std::optional<double> poisson_ratio, std::optional<double> tool_diameter_mm,
             const std::string& contact_law, bool plastic, std::optional<double> yield_stress_pa,
             const std::vector<std::string>& flags) {
            return hapvox::Model::voxel(
                volume, model_options("voxel", youngs_modulus_pa, poisson_ratio, tool_diameter_mm,
                                      contact_law, plastic, yield_stress_pa, "", "", flags));
          },
          py::arg("volume"), py::arg("youngs_modulus_pa") = py::none(),
          py::arg("poisson_ratio") = py::none(), py::arg("tool_diameter_mm") = py::none(),
          py::arg("contact_law") = "", py::arg("plastic") = false,
          py::arg("yield_stress_pa") = py::none(), py::arg("flags") = std::vector<std::string>{})
      .def_static(
          "fem",
          [](const hapvox::Volume& volume, const std::string& materials, const std::string& labels,
             std::optional<double> youngs_modulus_pa, std::optional<double> poisson_ratio,
             std::optional<double> tool_diameter_mm, const std::vector<std::string>& flags) {
            const hapvox::ModelOptions o =
                model_options("fem", youngs_modulus_pa, poisson_ratio, tool_diameter_mm, "", false,
                              std::nullopt, materials, labels, flags);
            py::gil_scoped_release release;  // meshing and factoring take a while
            return hapvox::Model::fem(volume, o);
          },
          py::arg("volume"), py::arg("materials"), py::arg("labels") = "",
          py::arg("youngs_modulus_pa") = py::none(), py::arg("poisson_ratio") = py::none(),
          py::arg("tool_diameter_mm") = py::none(), py::arg("flags") = std::vector<std::string>{},
          "Nakao's proxy-FEM model of the volume's labelled regions (its materials file)")
      .def_property_readonly("tool_radius_mm", &hapvox::Model::tool_radius_mm)
      .def_property_readonly("volume", &hapvox::Model::volume);

  py::class_<PythonDevice>(m, "Device", "What moves the tool: a trace or a Python callback")
      .def_static(
          "trace",
          [](const hapvox::Trace& trace, double scale, const py::object& rotate_deg,
             const py::object& offset_mm, double rate_hz, double max_gap_s) {
            return PythonDevice{
                hapvox::Device::trace(trace, transform_of(scale, rotate_deg, offset_mm), rate_hz,
                                      max_gap_s),
                nullptr};
          },
          py::arg("trace"), py::arg("scale") = 1.0,
          py::arg("rotate_deg") = std::array<double, 3>{0, 0, 0},
          py::arg("offset_mm") = std::array<double, 3>{0, 0, 0}, py::arg("rate_hz") = 1000.0,
          py::arg("max_gap_s") = 0.05)
      .def_static(
          "callback",
          [](py::function read, std::size_t ticks, double rate_hz, double scale,
             const py::object& rotate_deg, const py::object& offset_mm, py::object on_force) {
            // The loop runs without the GIL: each call takes it back. An exception in a
            // callback must not unwind through the loop (in realtime, the force thread): the
            // first is kept and raised once the run is over; the tool holds meanwhile.
            auto error = std::make_shared<CallbackError>();
            hapvox::DeviceReadFn read_fn = [read, error](std::size_t tick) {
              hapvox::ToolSample s;
              py::gil_scoped_acquire gil;
              try {
                s.position_mm = as_vec3(read(tick), "device callback");
                error->last_position_mm = s.position_mm;
              } catch (py::error_already_set& e) {
                error->keep("read", tick, python_error_text(e));
                s.position_mm = error->last_position_mm;
                s.holding = true;
              } catch (const std::exception& e) {
                error->keep("read", tick, e.what());
                s.position_mm = error->last_position_mm;
                s.holding = true;
              }
              return s;
            };
            hapvox::DeviceForceFn force_fn;
            if (!on_force.is_none()) {
              force_fn = [on_force, error](std::size_t tick, const std::array<double, 3>& f) {
                py::gil_scoped_acquire gil;
                try {
                  on_force(tick, vec3(f));
                } catch (py::error_already_set& e) {
                  error->keep("on_force", tick, python_error_text(e));
                } catch (const std::exception& e) {
                  error->keep("on_force", tick, e.what());
                }
              };
            }
            return PythonDevice{
                hapvox::Device::callback(read_fn, ticks, rate_hz,
                                         transform_of(scale, rotate_deg, offset_mm), force_fn),
                error};
          },
          py::arg("read"), py::arg("ticks"), py::arg("rate_hz") = 1000.0, py::arg("scale") = 1.0,
          py::arg("rotate_deg") = std::array<double, 3>{0, 0, 0},
          py::arg("offset_mm") = std::array<double, 3>{0, 0, 0}, py::arg("on_force") = py::none(),
          "read(tick) -> the tool's position (3 numbers, device frame); on_force(tick, force_n). "
          "An exception in either is raised as RuntimeError once the run ends")
      .def_property_readonly("rate_hz", [](const PythonDevice& d) { return d.device.rate_hz(); })
      .def_property_readonly("ticks", [](const PythonDevice& d) { return d.device.ticks(); });

  py::class_<hapvox::Session>(m, "Session", "A session file's datasets (numpy) and attributes")
      .def_static("open", &hapvox::Session::open, py::arg("path"))
      .def_property_readonly("rows", &hapvox::Session::rows)
      .def_property_readonly("complete", &hapvox::Session::complete)
      .def_property_readonly("path", &hapvox::Session::path)
      .def_property_readonly("datasets", &hapvox::Session::dataset_names)
      .def_property_readonly("attributes",
                             [](const hapvox::Session& s) {
                               py::dict d;
                               for (const auto& [k, v] : s.attributes()) d[py::str(k)] = v;
                               return d;
                             })
      .def("__getitem__", &dataset_array, py::arg("name"))
      .def("__contains__", &hapvox::Session::has_dataset)
      .def("__getattr__", [](const hapvox::Session& s, const std::string& name) -> py::object {
        if (!s.has_dataset(name)) throw py::attribute_error("Session has no dataset " + name);
        return dataset_array(s, name);
      });

  py::class_<hapvox::RunSummary>(m, "RunSummary")
      .def_readonly("ticks", &hapvox::RunSummary::ticks)
      .def_readonly("contact_ticks", &hapvox::RunSummary::contact_ticks)
      .def_readonly("peak_force_n", &hapvox::RunSummary::peak_force_n)
      .def_readonly("clamped_ticks", &hapvox::RunSummary::clamped_ticks)
      .def_readonly("nonfinite_forces", &hapvox::RunSummary::nonfinite_forces)
      .def_readonly("motion_faults", &hapvox::RunSummary::motion_faults)
      .def_readonly("compute_p50_us", &hapvox::RunSummary::compute_p50_us)
      .def_readonly("compute_p99_us", &hapvox::RunSummary::compute_p99_us)
      .def_readonly("lateness_p99_us", &hapvox::RunSummary::lateness_p99_us)
      .def_readonly("watchdog_trips", &hapvox::RunSummary::watchdog_trips)
      .def_readonly("initial_mass_units", &hapvox::RunSummary::initial_mass_units)
      .def_readonly("final_mass_units", &hapvox::RunSummary::final_mass_units);

  py::class_<hapvox::ForceTick>(m, "ForceTick")
      .def_property_readonly("force_n", [](const hapvox::ForceTick& t) { return vec3(t.force_n); })
      .def_property_readonly("force_device_n",
                             [](const hapvox::ForceTick& t) { return vec3(t.force_device_n); })
      .def_property_readonly("tool_position_mm",
                             [](const hapvox::ForceTick& t) { return vec3(t.tool_position_mm); })
      .def_property_readonly("displacement_mm",
                             [](const hapvox::ForceTick& t) { return vec3(t.displacement_mm); })
      .def_readonly("force_scale", &hapvox::ForceTick::force_scale)
      .def_readonly("contact_area_mm2", &hapvox::ForceTick::contact_area_mm2)
      .def_readonly("contact", &hapvox::ForceTick::contact)
      .def_readonly("clamped", &hapvox::ForceTick::clamped)
      .def_readonly("fault", &hapvox::ForceTick::fault)
      .def("as_dict", &tick_dict);

  py::class_<hapvox::ForceStage>(m, "ForceStage", "One 1 kHz tick per call, from your own loop")
      .def(py::init([](const hapvox::Model& model, double max_force_n, double ramp_in_s,
                       double rate_hz, double scale, const py::object& rotate_deg,
                       const py::object& offset_mm) {
             return std::make_unique<hapvox::ForceStage>(
                 model, loop_options(max_force_n, ramp_in_s, ""), rate_hz,
                 transform_of(scale, rotate_deg, offset_mm));
           }),
           py::arg("model"), py::arg("max_force_n") = 10.0, py::arg("ramp_in_s") = 0.1,
           py::arg("rate_hz") = 1000.0, py::arg("scale") = 1.0,
           py::arg("rotate_deg") = std::array<double, 3>{0, 0, 0},
           py::arg("offset_mm") = std::array<double, 3>{0, 0, 0})
      .def(
          "step",
          [](hapvox::ForceStage& stage, const py::object& position_mm, double time_s,
             bool holding) {
            hapvox::ToolSample s;
            s.position_mm = as_vec3(position_mm, "position_mm");
            s.time_s = time_s;
            s.holding = holding;
            return stage.step(s);
          },
          py::arg("position_mm"), py::arg("time_s") = 0.0, py::arg("holding") = false,
          "The next tick's force for the tool at position_mm (device frame)")
      .def(
          "step_many",
          [](hapvox::ForceStage& stage, const Array& positions_mm) {
            if (positions_mm.ndim() != 2 || positions_mm.shape(1) != 3) {
              throw InputError("positions_mm", "expected shape (N, 3)");
            }
            const std::size_t n = static_cast<std::size_t>(positions_mm.shape(0));
            py::array_t<double> forces({static_cast<py::ssize_t>(n), py::ssize_t{3}});
            const double* in = positions_mm.data();
            double* out = forces.mutable_data();
            {
              py::gil_scoped_release release;
              for (std::size_t k = 0; k < n; ++k) {
                hapvox::ToolSample s;
                s.position_mm = {in[3 * k], in[3 * k + 1], in[3 * k + 2]};
                const hapvox::ForceTick t = stage.step(s);
                std::memcpy(out + 3 * k, t.force_n.data(), 3 * sizeof(double));
              }
            }
            return forces;
          },
          py::arg("positions_mm"), "N ticks at once (the GIL released): forces, shape (N, 3)")
      .def_property_readonly("ticks", &hapvox::ForceStage::ticks);

  m.def(
      "replay",
      [](const std::string& volume, const std::string& trace, const std::string& output,
         const std::string& model, std::optional<double> youngs_modulus_pa,
         std::optional<double> poisson_ratio, std::optional<double> tool_diameter_mm,
         const std::string& contact_law, bool plastic, std::optional<double> yield_stress_pa,
         const std::string& materials, const std::string& labels, std::optional<double> threshold,
         std::optional<std::array<double, 2>> window, bool realtime,
         const std::vector<std::string>& flags) {
        hapvox::ReplayOptions o;
        o.volume = volume;
        o.trace = trace;
        o.output = output;
        o.model = model_options(model, youngs_modulus_pa, poisson_ratio, tool_diameter_mm,
                                contact_law, plastic, yield_stress_pa, materials, labels, {});
        o.intensity = intensity_options(threshold, window);
        o.realtime = realtime;
        o.flags = flags;
        py::gil_scoped_release release;
        return hapvox::replay(o);
      },
      py::arg("volume"), py::arg("trace"), py::arg("output") = "", py::arg("model") = "voxel",
      py::arg("youngs_modulus_pa") = py::none(), py::arg("poisson_ratio") = py::none(),
      py::arg("tool_diameter_mm") = py::none(), py::arg("contact_law") = "",
      py::arg("plastic") = false, py::arg("yield_stress_pa") = py::none(),
      py::arg("materials") = "", py::arg("labels") = "", py::arg("threshold") = py::none(),
      py::arg("window") = py::none(), py::arg("realtime") = false,
      py::arg("flags") = std::vector<std::string>{},
      "`hapvox replay` as a function: returns the Session (output='' keeps it in memory only)");
  m.def(
      "run_sweep_row",
      [](const std::string& manifest, std::size_t row, const std::string& output) {
        py::gil_scoped_release release;
        return hapvox::run_sweep_row(manifest, row, output);
      },
      py::arg("manifest"), py::arg("row"), py::arg("output") = "");
  for (const char* name : {"run_lockstep", "run_realtime"}) {
    const bool realtime = std::string(name) == "run_realtime";
    m.def(
        name,
        [realtime](const hapvox::Model& model, PythonDevice& device, double max_force_n,
                   double ramp_in_s, const std::string& session_path) {
          const hapvox::LoopOptions o = loop_options(max_force_n, ramp_in_s, session_path);
          return run_device(device, [&](hapvox::Device& d) {
            return realtime ? hapvox::run_realtime(model, d, o) : hapvox::run_lockstep(model, d, o);
          });
        },
        py::arg("model"), py::arg("device"), py::arg("max_force_n") = 10.0,
        py::arg("ramp_in_s") = 0.1, py::arg("session_path") = "",
        realtime ? "Runs the device in realtime on a force thread (docs/api.md)"
                 : "Runs every tick of the device on a simulated clock (bit-reproducible)");
  }
}
