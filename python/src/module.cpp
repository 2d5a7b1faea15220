// microshadow._microshadow: the pybind11 layer over the public C++ API (<microshadow/microshadow.hpp>).
// It converts numpy arrays and option strings, releases the GIL around long calls and turns Ctrl-C into
// KeyboardInterrupt; the argument checks that name the argument and index, the broadcasting and the
// documentation live in the Python package (python/microshadow/__init__.py).
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <microshadow/microshadow.hpp>

#include <chrono>
#include <condition_variable>
#include <cstring>
#include <exception>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>

namespace py = pybind11;
using namespace microshadow;
using namespace pybind11::literals;

namespace {

using Doubles = py::array_t<double, py::array::c_style | py::array::forcecast>;

// --- option strings, spelled as the CLI's -----------------------------------------------------------

Method parse_method(const std::string& s) {
    if (s == "exact") return Method::exact;
    if (s == "sampled") return Method::sampled;
    throw std::invalid_argument("method = '" + s + "' (exact or sampled)");
}
Backend parse_backend(const std::string& s) {
    if (s == "opencl") return Backend::opencl;
    if (s == "oracle") return Backend::oracle;
    throw std::invalid_argument("backend = '" + s + "' (opencl or oracle)");
}
Sequence parse_sequence(const std::string& s) {
    if (s == "sobol") return Sequence::sobol;
    if (s == "random") return Sequence::random;
    throw std::invalid_argument("sequence = '" + s + "' (sobol or random)");
}
Form parse_form(const std::string& s) {
    if (s == "height-correlated") return Form::height_correlated;
    if (s == "uncorrelated") return Form::uncorrelated;
    throw std::invalid_argument("form = '" + s + "' (height-correlated or uncorrelated)");
}
AoWeighting parse_ao_weighting(const std::string& s) {
    if (s == "cosine") return AoWeighting::cosine;
    if (s == "uniform") return AoWeighting::uniform;
    throw std::invalid_argument("ao_weighting = '" + s + "' (cosine or uniform)");
}

// --- progress, Ctrl-C and the GIL --------------------------------------------------------------------

// The Progress of one long call. Each report takes the GIL for a moment and calls the user's callback;
// the calling thread meanwhile runs Python's signal handlers every 0.1 s (check_signals: Ctrl-C raises
// KeyboardInterrupt there). Python runs signal handlers only in its main thread, and the library
// reports progress from whichever worker thread finishes an item, so the reports cannot be where
// Ctrl-C is noticed. Either raising stops the call (the next report returns false and the C++ side
// throws Cancelled); the Python exception is kept and raised again once the call has unwound.
class PythonProgress {
public:
    explicit PythonProgress(py::object callback) : callback_(std::move(callback)) {}
    ~PythonProgress() {
        if (type_ || value_ || traceback_) {
            py::gil_scoped_acquire gil;
            Py_XDECREF(type_);
            Py_XDECREF(value_);
            Py_XDECREF(traceback_);
        }
    }
    Progress progress() {
        return [this](std::uint64_t done, std::uint64_t total) {
            py::gil_scoped_acquire gil;
            if (pending()) return false;
            if (!callback_.is_none()) {
                try {
                    callback_(done, total);
                } catch (py::error_already_set& e) {
                    e.restore();
                    keep_error();
                    return false;
                }
            }
            return true;
        };
    }
    // Whether a signal handler or the callback raised (their exception is kept for raise()).
    bool stopped() const { return pending(); }
    // Runs Python's signal handlers (the caller holds the GIL); one that raises stops the call.
    void check_signals() {
        if (!pending() && PyErr_CheckSignals() != 0) keep_error();
    }
    // After Cancelled: the exception that stopped the call (KeyboardInterrupt when none was kept).
    [[noreturn]] void raise() {
        if (pending()) {
            PyErr_Restore(type_, value_, traceback_);
            type_ = value_ = traceback_ = nullptr;
            throw py::error_already_set();
        }
        PyErr_SetNone(PyExc_KeyboardInterrupt);
        throw py::error_already_set();
    }

private:
    bool pending() const { return type_ != nullptr; }
    void keep_error() { PyErr_Fetch(&type_, &value_, &traceback_); }
    py::object callback_;
    PyObject* type_ = nullptr;
    PyObject* value_ = nullptr;
    PyObject* traceback_ = nullptr;
};

// Runs `call(progress)` on a thread of its own without the GIL (so other Python threads run
// meanwhile), while this thread wakes every 0.1 s to run Python's signal handlers.
template <class Call>
auto run_long(const py::object& callback, Call&& call) {
    using Result = decltype(call(std::declval<Progress>()));
    PythonProgress bridge(callback);
    std::optional<Result> result;
    std::exception_ptr failure;
    std::mutex mutex;
    std::condition_variable finished;
    bool done = false;
    {
        py::gil_scoped_release release;
        std::thread worker([&] {
            try {
                result.emplace(call(bridge.progress()));
            } catch (...) {
                failure = std::current_exception();
            }
            const std::lock_guard<std::mutex> lock(mutex);
            done = true;
            finished.notify_one();
        });
        std::unique_lock<std::mutex> lock(mutex);
        while (!finished.wait_for(lock, std::chrono::milliseconds(100), [&] { return done; })) {
            lock.unlock();
            {
                py::gil_scoped_acquire gil;
                bridge.check_signals();
            }
            lock.lock();
        }
        lock.unlock();
        worker.join();
    }
    if (failure) {
        try {
            std::rethrow_exception(failure);
        } catch (const Cancelled&) {
            bridge.raise();
        }
    }
    // A Ctrl-C (or a callback's exception) after the last report still stops the caller.
    if (bridge.stopped()) bridge.raise();
    return std::move(*result);
}

template <class T>
py::array_t<T> to_array(const std::vector<T>& values, std::vector<py::ssize_t> shape) {
    py::array_t<T> out(shape);
    if (!values.empty()) std::memcpy(out.mutable_data(), values.data(), values.size() * sizeof(T));
    return out;
}

SamplingOptions sampling_options(const std::string& method, double tolerance, std::uint64_t samples, std::uint32_t replicates,
                                 std::uint64_t seed, const std::string& sequence, const std::string& form,
                                 const std::string& ao_weighting, const std::string& backend, const std::string& device,
                                 bool fast_math, bool exact_float) {
    SamplingOptions o;
    o.method = parse_method(method);
    o.tolerance = tolerance;
    o.samples = samples;
    o.replicates = replicates;
    o.seed = seed;
    o.sequence = parse_sequence(sequence);
    o.form = parse_form(form);
    o.ao_weighting = parse_ao_weighting(ao_weighting);
    o.backend = parse_backend(backend);
    o.device = device;
    o.fast_math = fast_math;
    o.exact_float = exact_float;
    return o;
}

// (N, 9) rows of visibility, alpha_x, alpha_y, wi (3), wo (3) -> (N, 2) of term, std_error.
py::array_t<double> evaluate_rows(const Doubles& rows, const SamplingOptions& options, const py::object& progress) {
    if (rows.ndim() != 2 || rows.shape(1) != 9) throw std::invalid_argument("queries must be an (N, 9) array");
    const std::size_t n = std::size_t(rows.shape(0));
    std::vector<Query> queries(n);
    const double* r = rows.data();
    for (std::size_t i = 0; i < n; ++i, r += 9)
        queries[i] = {r[0], r[1], r[2], {r[3], r[4], r[5]}, {r[6], r[7], r[8]}};
    const std::vector<Estimate> got = run_long(progress, [&](const Progress& p) { return evaluate(queries, options, p); });
    std::vector<double> flat(2 * n);
    for (std::size_t i = 0; i < n; ++i) {
        flat[2 * i] = got[i].value;
        flat[2 * i + 1] = got[i].std_error;
    }
    return to_array(flat, {py::ssize_t(n), 2});
}

// (N, 9) query rows -> (N, 5) rows of visibility, n_dot_l, n_dot_v, roughness, relative azimuth (degrees).
py::array_t<double> lookup_input_rows(const Doubles& rows) {
    if (rows.ndim() != 2 || rows.shape(1) != 9) throw std::invalid_argument("queries must be an (N, 9) array");
    const std::size_t n = std::size_t(rows.shape(0));
    std::vector<double> flat(5 * n);
    const double* r = rows.data();
    for (std::size_t i = 0; i < n; ++i, r += 9) {
        const LookupInputs in = lookup_inputs({r[0], r[1], r[2], {r[3], r[4], r[5]}, {r[6], r[7], r[8]}});
        const double row[5] = {in.visibility, in.n_dot_l, in.n_dot_v, in.roughness, in.relative_azimuth_degrees};
        std::memcpy(&flat[5 * i], row, sizeof row);
    }
    return to_array(flat, {py::ssize_t(n), 5});
}

// (N, 5) rows of visibility, n_dot_l, n_dot_v, roughness, relative azimuth (degrees), the order of
// every isotropic call (and of lookup_rows) -> (N, 9) query rows, by isotropic_query.
py::array_t<double> isotropic_rows(const Doubles& params) {
    if (params.ndim() != 2 || params.shape(1) != 5) throw std::invalid_argument("params must be an (N, 5) array");
    const std::size_t n = std::size_t(params.shape(0));
    std::vector<double> flat(9 * n);
    const double* p = params.data();
    for (std::size_t i = 0; i < n; ++i, p += 5) {
        const Query q = isotropic_query(p[0], p[1], p[2], Roughness(p[3]), p[4]);
        const double row[9] = {q.visibility, q.alpha_x, q.alpha_y, q.wi.x, q.wi.y, q.wi.z, q.wo.x, q.wo.y, q.wo.z};
        std::memcpy(&flat[9 * i], row, sizeof row);
    }
    return to_array(flat, {py::ssize_t(n), 9});
}

double lookup_one(const LookupFile& f, const double* r) { return f.lookup(r[0], r[1], r[2], Roughness(r[3]), r[4]); }
double lookup_one(const Lut& f, const double* r) { return f.lookup(r[0], r[1], r[2], Roughness(r[3])); }

// (N, 5) rows of visibility, n_dot_l, n_dot_v, roughness, relative azimuth (degrees) -> (N,) lookups
// (a LUT ignores the azimuth).
template <class Table>
py::array_t<double> lookup_rows(const Table& file, const Doubles& rows) {
    if (rows.ndim() != 2 || rows.shape(1) != 5) throw std::invalid_argument("lookup rows must be an (N, 5) array");
    const std::size_t n = std::size_t(rows.shape(0));
    std::vector<double> out(n);
    const double* r = rows.data();
    {
        py::gil_scoped_release release;
        for (std::size_t i = 0; i < n; ++i, r += 5) {
            try {
                out[i] = lookup_one(file, r);
            } catch (const std::domain_error& e) {
                throw std::domain_error("lookup " + std::to_string(i) + ": " + e.what());
            }
        }
    }
    return to_array(out, {py::ssize_t(n)});
}

// (N, 4) rows of visibility, n_dot_l, n_dot_v, roughness -> (N,) values of the analytic term.
py::array_t<double> analytic_rows(const std::string& name, const Doubles& rows, const std::string& ao_weighting) {
    if (rows.ndim() != 2 || rows.shape(1) != 4) throw std::invalid_argument("analytic rows must be an (N, 4) array");
    const std::size_t n = std::size_t(rows.shape(0));
    std::vector<AnalyticInputs> inputs(n);
    const double* r = rows.data();
    for (std::size_t i = 0; i < n; ++i, r += 4) inputs[i] = {r[0], r[1], r[2], r[3]};
    return to_array(analytic_term(name, inputs, parse_ao_weighting(ao_weighting)), {py::ssize_t(n)});
}

py::dict table_dict(const SweepTable& t) {
    py::dict out;
    for (std::size_t k = 0; k < t.columns.size(); ++k) {
        if (!t.texts[k].empty() || t.numbers[k].empty()) {
            py::list texts;
            for (const auto& s : t.texts[k]) texts.append(s);
            out[py::str(t.columns[k])] = py::module_::import("numpy").attr("array")(texts, "dtype"_a = "U");
        } else {
            out[py::str(t.columns[k])] = to_array(t.numbers[k], {py::ssize_t(t.numbers[k].size())});
        }
    }
    return out;
}

// A cubemap as a (6, size, size, 3) float32 array (faces +X -X +Y -Y +Z -Z).
py::array_t<float> cube_array(const CubeImage& c) {
    return to_array(c.texels, {6, py::ssize_t(c.size), py::ssize_t(c.size), 3});
}

EnvironmentSource environment_source(const std::string& image, const std::vector<std::string>& faces) {
    EnvironmentSource e;
    e.image = image;
    e.faces = faces;
    return e;
}

// (N, 6) rows of visibility, alpha_x, alpha_y, wi (3) and (N, 4) sphere rows (centre (3), half-angle in
// degrees) or (N, 12) rectangle rows (the corners) -> the queries of area_evaluate.
std::vector<AreaQuery> area_queries(const Doubles& surface, const Doubles& light, LightShape shape) {
    const py::ssize_t light_columns = shape == LightShape::sphere ? 4 : 12;
    if (surface.ndim() != 2 || surface.shape(1) != 6) throw std::invalid_argument("surface rows must be an (N, 6) array");
    if (light.ndim() != 2 || light.shape(1) != light_columns || light.shape(0) != surface.shape(0))
        throw std::invalid_argument("light rows must be (N, " + std::to_string(light_columns) + ")");
    const std::size_t n = std::size_t(surface.shape(0));
    std::vector<AreaQuery> queries(n);
    for (std::size_t i = 0; i < n; ++i) {
        const double* s = surface.data() + 6 * i;
        const double* l = light.data() + light_columns * i;
        AreaQuery& q = queries[i];
        q.visibility = s[0];
        q.alpha_x = s[1];
        q.alpha_y = s[2];
        q.wi = {s[3], s[4], s[5]};
        q.shape = shape;
        if (shape == LightShape::sphere) {
            q.centre = {l[0], l[1], l[2]};
            q.half_angle_degrees = l[3];
        } else {
            for (int k = 0; k < 4; ++k) q.corners[k] = {l[3 * k], l[3 * k + 1], l[3 * k + 2]};
        }
    }
    return queries;
}

}  // namespace

PYBIND11_MODULE(_microshadow, m) {
    m.doc() = "microshadow's C++ engine (use the microshadow package, which checks and documents the arguments)";
    m.def("version", &version);

    m.def(
        "evaluate_rows",
        [](const Doubles& rows, const std::string& method, double tolerance, std::uint64_t samples, std::uint32_t replicates,
           std::uint64_t seed, const std::string& sequence, const std::string& form, const std::string& ao_weighting,
           const std::string& backend, const std::string& device, bool fast_math, bool exact_float, const py::object& progress) {
            return evaluate_rows(rows,
                                 sampling_options(method, tolerance, samples, replicates, seed, sequence, form, ao_weighting,
                                                  backend, device, fast_math, exact_float),
                                 progress);
        },
        "rows"_a, "method"_a, "tolerance"_a, "samples"_a, "replicates"_a, "seed"_a, "sequence"_a, "form"_a, "ao_weighting"_a,
        "backend"_a, "device"_a, "fast_math"_a, "exact_float"_a, "progress"_a);
    m.def("isotropic_rows", &isotropic_rows, "params"_a);
    m.def("lookup_input_rows", &lookup_input_rows, "rows"_a);

    py::class_<LookupFile>(m, "LookupFile")
        .def_property_readonly("kind", &LookupFile::kind)
        .def_property_readonly("keeps_azimuth", &LookupFile::keeps_azimuth)
        .def_property_readonly("metadata_json", &LookupFile::metadata_json)
        .def("lookup_rows", &lookup_rows<LookupFile>, "rows"_a)
        .def("lut", &LookupFile::lut, py::return_value_policy::copy)
        .def("texture",
             [](const LookupFile& f) {
                 return to_array(f.texture(), {py::ssize_t(f.texture_depth()), py::ssize_t(f.texture_height()),
                                               py::ssize_t(f.texture_width()), 4});
             })
        .def("save", [](const LookupFile& f, const std::string& path, bool half) {
            py::gil_scoped_release release;
            f.save(path, half);
        }, "path"_a, "half"_a = false);
    py::class_<Lut>(m, "Lut")
        .def_property_readonly("visibility_count", &Lut::visibility_count)
        .def_property_readonly("n_dot_l_count", &Lut::n_dot_l_count)
        .def_property_readonly("n_dot_v_count", &Lut::n_dot_v_count)
        .def_property_readonly("roughness", &Lut::roughness)
        .def_property_readonly("max_total_error", &Lut::max_total_error)
        .def_property_readonly("metadata_json", &Lut::metadata_json)
        .def("axis_values", &Lut::axis_values, "axis"_a)
        .def("texels",
             [](const Lut& lut) {
                 return to_array(lut.texels(), {py::ssize_t(lut.n_dot_v_count()), py::ssize_t(lut.n_dot_l_count()),
                                                py::ssize_t(lut.visibility_count()), py::ssize_t(lut.roughness().size())});
             })
        .def("lookup_rows", &lookup_rows<Lut>, "rows"_a)
        .def("save", [](const Lut& lut, const std::string& path, const std::string& encoding) {
            py::gil_scoped_release release;
            lut.save(path, encoding);
        }, "path"_a, "encoding"_a = "");
    m.def("open_file", [](const std::string& path) {
        py::gil_scoped_release release;
        return open_file(path);
    }, "path"_a);
    m.def(
        "bake",
        [](const std::string& layout, std::uint32_t size, std::uint32_t size_visibility, std::uint32_t size_n_dot_l,
           std::uint32_t size_n_dot_v, const std::vector<double>& roughness, const std::vector<double>& visibility_range,
           const std::vector<double>& n_dot_l_range, const std::vector<double>& n_dot_v_range, const std::string& texel,
           const std::string& azimuth, double tolerance, std::uint32_t max_batches, const std::string& method,
           std::uint64_t samples, std::uint32_t replicates, std::uint64_t seed, const std::string& sequence,
           const std::string& form, const std::string& ao_weighting, const std::string& backend, const std::string& device,
           bool fast_math, bool exact_float, const py::object& progress) {
            BakeOptions o;
            o.layout = layout;
            o.size = size;
            o.visibility_count = size_visibility;
            o.n_dot_l_count = size_n_dot_l;
            o.n_dot_v_count = size_n_dot_v;
            o.roughness = roughness;
            o.visibility_range = visibility_range;
            o.n_dot_l_range = n_dot_l_range;
            o.n_dot_v_range = n_dot_v_range;
            o.texel = texel;
            o.azimuth = azimuth;
            o.tolerance = tolerance;
            o.max_batches = max_batches;
            o.sampling = sampling_options(method, 0, samples, replicates, seed, sequence, form, ao_weighting, backend, device,
                                          fast_math, exact_float);
            return run_long(progress, [&](const Progress& p) { return bake(o, p); });
        },
        "layout"_a, "size"_a, "size_visibility"_a, "size_n_dot_l"_a, "size_n_dot_v"_a, "roughness"_a, "visibility_range"_a,
        "n_dot_l_range"_a, "n_dot_v_range"_a, "texel"_a, "azimuth"_a, "tolerance"_a, "max_batches"_a, "method"_a, "samples"_a,
        "replicates"_a, "seed"_a, "sequence"_a, "form"_a, "ao_weighting"_a, "backend"_a, "device"_a, "fast_math"_a,
        "exact_float"_a, "progress"_a);

    m.def(
        "repr_bake",
        [](const std::string& preset, const std::string& kind, std::uint32_t visibility_count, std::uint32_t n_dot_l_count,
           std::uint32_t n_dot_v_count, std::uint32_t azimuth_nodes, const std::vector<double>& roughness, std::uint32_t roughness_count,
           const std::string& n_dot_v_warp, const std::string& n_dot_l_warp, const std::string& visibility_warp,
           const std::string& method, double tolerance, std::uint64_t samples, std::uint32_t replicates, std::uint64_t seed,
           const std::string& sequence, const std::string& form, const std::string& ao_weighting, const std::string& backend,
           const std::string& device, bool fast_math, bool exact_float, const py::object& progress) {
            ReprBakeOptions o;
            o.preset = preset;
            o.kind = kind;
            o.visibility_count = visibility_count;
            o.n_dot_l_count = n_dot_l_count;
            o.n_dot_v_count = n_dot_v_count;
            o.azimuth_nodes = azimuth_nodes;
            o.roughness = roughness;
            o.roughness_count = roughness_count;
            o.n_dot_v_warp = n_dot_v_warp;
            o.n_dot_l_warp = n_dot_l_warp;
            o.visibility_warp = visibility_warp;
            o.sampling = sampling_options(method, tolerance, samples, replicates, seed, sequence, form, ao_weighting, backend,
                                          device, fast_math, exact_float);
            return run_long(progress, [&](const Progress& p) { return repr_bake(o, p); });
        },
        "preset"_a, "kind"_a, "visibility_count"_a, "n_dot_l_count"_a, "n_dot_v_count"_a, "azimuth_nodes"_a, "roughness"_a,
        "roughness_count"_a, "n_dot_v_warp"_a, "n_dot_l_warp"_a, "visibility_warp"_a, "method"_a, "tolerance"_a, "samples"_a,
        "replicates"_a, "seed"_a, "sequence"_a, "form"_a, "ao_weighting"_a, "backend"_a, "device"_a, "fast_math"_a,
        "exact_float"_a, "progress"_a);

    m.def("analytic_term_names", &analytic_term_names);
    m.def("analytic_rows", &analytic_rows, "name"_a, "rows"_a, "ao_weighting"_a);

    m.def(
        "sweep",
        [](const std::string& spec_path, const std::string& toml, const std::string& base_dir, const std::string& out_dir,
           const std::optional<std::string>& method, const std::optional<double>& tolerance,
           const std::optional<std::uint64_t>& samples, const std::optional<std::uint32_t>& replicates,
           const std::optional<std::uint64_t>& seed, const std::optional<std::string>& sequence,
           const std::optional<std::string>& form, const std::optional<std::string>& ao_weighting, const std::string& backend,
           const std::string& device, bool fast_math, bool exact_float, const py::object& progress) {
            SweepOptions o;
            o.out_dir = out_dir;
            if (method) o.method = parse_method(*method);
            o.tolerance = tolerance;
            o.samples = samples;
            o.replicates = replicates;
            o.seed = seed;
            if (sequence) o.sequence = parse_sequence(*sequence);
            if (form) o.form = parse_form(*form);
            if (ao_weighting) o.ao_weighting = parse_ao_weighting(*ao_weighting);
            o.backend = parse_backend(backend);
            o.device = device;
            o.fast_math = fast_math;
            o.exact_float = exact_float;
            const SweepTable table = run_long(progress, [&](const Progress& p) {
                return spec_path.empty() ? sweep_toml(toml, base_dir, o, p) : sweep(spec_path, o, p);
            });
            py::dict out = table_dict(table);
            return py::make_tuple(out, table.summary_markdown);
        },
        "spec_path"_a, "toml"_a, "base_dir"_a, "out_dir"_a, "method"_a, "tolerance"_a, "samples"_a, "replicates"_a, "seed"_a,
        "sequence"_a, "form"_a, "ao_weighting"_a, "backend"_a, "device"_a, "fast_math"_a, "exact_float"_a, "progress"_a);

    py::class_<DfgLut>(m, "DfgLut")
        .def_property_readonly("metadata_json", &DfgLut::metadata_json)
        .def_property_readonly("n_dot_v", &DfgLut::n_dot_v_values)
        .def_property_readonly("roughness", &DfgLut::roughness_values)
        .def_property_readonly("channels", &DfgLut::channels)
        .def("values", [](const DfgLut& d) {
            return to_array(d.values(), {py::ssize_t(d.roughness_count()), py::ssize_t(d.n_dot_v_count()),
                                         py::ssize_t(d.channels().size())});
        })
        .def("std_errors", [](const DfgLut& d) {
            return to_array(d.std_errors(), {py::ssize_t(d.roughness_count()), py::ssize_t(d.n_dot_v_count()),
                                             py::ssize_t(d.channels().size())});
        })
        .def("save", [](const DfgLut& d, const std::string& path, bool half, const std::string& symbol) {
            py::gil_scoped_release release;
            d.save(path, half, symbol);
        }, "path"_a, "half"_a = false, "symbol"_a = "microshadow_dfg");
    m.def(
        "bake_dfg",
        [](std::uint32_t size, std::uint32_t size_n_dot_v, std::uint32_t size_roughness, const std::string& texel,
           const std::string& method, const std::string& channels, const std::string& parameterization,
           std::uint64_t samples, std::uint32_t replicates, std::uint64_t seed, const std::string& backend,
           const std::string& device, unsigned threads, bool fast_math, const py::object& progress) {
            DfgOptions o;
            o.size = size;
            o.n_dot_v_count = size_n_dot_v;
            o.roughness_count = size_roughness;
            o.texel = texel;
            o.method = method;
            o.channels = channels;
            o.parameterization = parameterization;
            o.samples = samples;
            o.replicates = replicates;
            o.seed = seed;
            o.backend = parse_backend(backend);
            o.device = device;
            o.threads = threads;
            o.fast_math = fast_math;
            return run_long(progress, [&](const Progress& p) { return bake_dfg(o, p); });
        },
        "size"_a, "size_n_dot_v"_a, "size_roughness"_a, "texel"_a, "method"_a, "channels"_a, "parameterization"_a,
        "samples"_a, "replicates"_a, "seed"_a, "backend"_a, "device"_a, "threads"_a, "fast_math"_a, "progress"_a);

    // --- area lights ---
    m.def(
        "area_evaluate",
        [](const Doubles& surface, const Doubles& light, const std::string& shape, const std::string& lobe,
           const std::string& method, double tolerance, std::uint64_t samples, std::uint32_t replicates, std::uint64_t seed,
           const std::string& sequence, const std::string& form, const std::string& ao_weighting, const std::string& backend,
           const std::string& device, bool fast_math, const py::object& progress) {
            if (shape != "sphere" && shape != "rect") throw std::invalid_argument("light = '" + shape + "' (sphere or rect)");
            if (lobe != "ggx" && lobe != "lambert") throw std::invalid_argument("lobe = '" + lobe + "' (ggx or lambert)");
            const std::vector<AreaQuery> queries = area_queries(surface, light, shape == "sphere" ? LightShape::sphere : LightShape::rect);
            AreaOptions o;
            o.lobe = lobe == "ggx" ? Lobe::ggx : Lobe::lambert;
            o.sampling = sampling_options(method, tolerance, samples, replicates, seed, sequence, form, ao_weighting, backend,
                                          device, fast_math, false);
            const std::vector<AreaEstimate> got =
                run_long(progress, [&](const Progress& p) { return area_evaluate(queries, o, p); });
            std::vector<double> flat(3 * got.size());
            for (std::size_t i = 0; i < got.size(); ++i) {
                flat[3 * i] = got[i].value;
                flat[3 * i + 1] = got[i].std_error;
                flat[3 * i + 2] = got[i].inner_error;
            }
            return to_array(flat, {py::ssize_t(got.size()), 3});
        },
        "surface"_a, "light"_a, "shape"_a, "lobe"_a, "method"_a, "tolerance"_a, "samples"_a, "replicates"_a, "seed"_a,
        "sequence"_a, "form"_a, "ao_weighting"_a, "backend"_a, "device"_a, "fast_math"_a, "progress"_a);

    // --- scenes ---
    py::class_<SceneResult>(m, "SceneResult")
        .def_property_readonly("width", &SceneResult::width)
        .def_property_readonly("height", &SceneResult::height)
        .def_property_readonly("lights", &SceneResult::lights)
        .def_property_readonly("comparators", &SceneResult::comparators)
        .def_property_readonly("report_json", &SceneResult::report_json)
        .def("layers",
             [](const SceneResult& r) {
                 py::dict out;
                 for (const SceneLayer& l : r.layers())
                     out[py::str(l.name)] = to_array(l.pixels, {py::ssize_t(r.height()), py::ssize_t(r.width())});
                 return out;
             })
        .def("save", [](const SceneResult& r, const std::string& dir) {
            py::gil_scoped_release release;
            r.save(dir);
        }, "dir"_a);
    m.def(
        "scene",
        [](const std::string& path, double tolerance, const std::optional<std::string>& method, const std::vector<std::string>& luts,
           bool skip, bool seed_luts, bool strict_domain, const std::string& backend, const std::string& device, bool fast_math,
           const py::object& progress) {
            SceneOptions o;
            o.tolerance = tolerance;
            if (method) o.method = parse_method(*method);
            o.luts = luts;
            o.skip = skip;
            o.seed_luts = seed_luts;
            o.strict_domain = strict_domain;
            o.backend = parse_backend(backend);
            o.device = device;
            o.fast_math = fast_math;
            return run_long(progress, [&](const Progress& p) { return scene(path, o, p); });
        },
        "path"_a, "tolerance"_a, "method"_a, "luts"_a, "skip"_a, "seed_luts"_a, "strict_domain"_a, "backend"_a, "device"_a,
        "fast_math"_a, "progress"_a);

    // --- environment integrals ---
    py::class_<PrefilteredEnvironment>(m, "PrefilteredEnvironment")
        .def_property_readonly("mip_roughness", &PrefilteredEnvironment::mip_roughness)
        .def_property_readonly("metadata_json", &PrefilteredEnvironment::metadata_json)
        .def("mips",
             [](const PrefilteredEnvironment& p) {
                 py::list out;
                 for (std::size_t k = 0; k < p.mip_count(); ++k) out.append(cube_array(p.mip(k)));
                 return out;
             })
        .def("irradiance", [](const PrefilteredEnvironment& p) { return cube_array(p.irradiance()); })
        .def("sh", [](const PrefilteredEnvironment& p) { return to_array(p.sh(), {9, 3}); })
        .def("save", [](const PrefilteredEnvironment& p, const std::string& dir, const std::string& format,
                        const std::string& encoding, double exposure) {
            py::gil_scoped_release release;
            p.save(dir, format, encoding, exposure);
        }, "dir"_a, "format"_a, "encoding"_a, "exposure"_a);
    m.def(
        "prefilter",
        [](const std::string& image, const std::vector<std::string>& faces, std::uint32_t size, std::uint32_t levels,
           const std::string& mapping, double tolerance, std::uint64_t samples, std::uint64_t max_samples, std::uint32_t replicates,
           std::uint64_t seed, bool filtered, double lod_bias, bool bright_auto, double bright_threshold, double bright_min_roughness,
           std::uint32_t wide_samples_factor,
           std::uint64_t bright_max, const std::string& device, unsigned threads, std::uint32_t verify,
           std::uint32_t irradiance_size, const py::object& progress) {
            PrefilterOptions o;
            o.environment = environment_source(image, faces);
            o.size = size;
            o.levels = levels;
            o.mapping = mapping;
            o.tolerance = tolerance;
            o.max_samples = max_samples;
            o.samples = samples;
            o.replicates = replicates;
            o.seed = seed;
            o.filtered = filtered;
            o.lod_bias = lod_bias;
            o.bright_auto = bright_auto;
            o.bright_threshold = bright_threshold;
            o.bright_min_roughness = bright_min_roughness;
            o.wide_samples_factor = wide_samples_factor;
            o.bright_max = bright_max;
            o.device = device;
            o.threads = threads;
            o.verify = verify;
            o.irradiance_size = irradiance_size;
            return run_long(progress, [&](const Progress& p) { return prefilter(o, p); });
        },
        "image"_a, "faces"_a, "size"_a, "levels"_a, "mapping"_a, "tolerance"_a, "samples"_a, "max_samples"_a, "replicates"_a, "seed"_a,
        "filtered"_a, "lod_bias"_a, "bright_auto"_a, "bright_threshold"_a, "bright_min_roughness"_a, "wide_samples_factor"_a, "bright_max"_a, "device"_a,
        "threads"_a, "verify"_a, "irradiance_size"_a, "progress"_a);

    py::class_<IrradianceMap>(m, "IrradianceMap")
        .def_property_readonly("metadata_json", &IrradianceMap::metadata_json)
        .def("map", [](const IrradianceMap& r) { return cube_array(r.map()); })
        .def("bound", [](const IrradianceMap& r) { return cube_array(r.bound()); })
        .def("save", [](const IrradianceMap& r, const std::string& dir, const std::string& format, const std::string& encoding,
                        double exposure) {
            py::gil_scoped_release release;
            r.save(dir, format, encoding, exposure);
        }, "dir"_a, "format"_a, "encoding"_a, "exposure"_a);
    m.def(
        "irradiance",
        [](const std::string& image, const std::vector<std::string>& faces, std::uint32_t face_size, std::uint32_t source_size,
           const std::string& backend, const std::string& device, unsigned threads, std::uint32_t verify,
           const py::object& progress) {
            IrradianceOptions o;
            o.environment = environment_source(image, faces);
            o.face_size = face_size;
            o.source_size = source_size;
            o.backend = parse_backend(backend);
            o.device = device;
            o.threads = threads;
            o.verify = verify;
            return run_long(progress, [&](const Progress& p) { return irradiance(o, p); });
        },
        "image"_a, "faces"_a, "face_size"_a, "source_size"_a, "backend"_a, "device"_a, "threads"_a, "verify"_a, "progress"_a);

    py::class_<ShIrradiance>(m, "ShIrradiance")
        .def_property_readonly("metadata_json", &ShIrradiance::metadata_json)
        .def("sh", [](const ShIrradiance& r) { return to_array(r.sh(), {9, 3}); })
        .def("irradiance", [](const ShIrradiance& r) { return cube_array(r.irradiance()); })
        .def("save", [](const ShIrradiance& r, const std::string& json, const std::string& irradiance, const std::string& preview,
                        const std::string& shader, const std::string& symbol) {
            py::gil_scoped_release release;
            r.save(json, irradiance, preview, shader, symbol);
        }, "json"_a, "irradiance"_a, "preview"_a, "shader"_a, "symbol"_a);
    m.def("spherical_harmonics", [](const std::string& image, const std::vector<std::string>& faces, std::uint32_t face_size) {
        py::gil_scoped_release release;
        return spherical_harmonics(environment_source(image, faces), face_size);
    }, "image"_a, "faces"_a, "face_size"_a);

    // --- the design study ---
    m.def(
        "design",
        [](const std::string& reference, const std::string& fit_reference, const std::string& cache,
           const std::vector<std::string>& luts, const std::vector<std::string>& reprs,
           const std::vector<std::string>& closed_forms, const std::vector<unsigned>& fit_orders, std::uint64_t max_bytes,
           unsigned max_fetches, unsigned max_alu, const std::string& choose, bool analytic, bool strict_domain,
           const std::string& backend, const std::string& device, const py::object& progress) {
            DesignOptions o;
            o.reference = reference;
            o.fit_reference = fit_reference;
            o.cache = cache;
            o.luts = luts;
            o.reprs = reprs;
            o.closed_forms = closed_forms;
            o.fit_orders = fit_orders;
            o.max_bytes = max_bytes;
            o.max_fetches = max_fetches;
            o.max_alu = max_alu;
            o.choose = choose;
            o.analytic = analytic;
            o.strict_domain = strict_domain;
            o.backend = parse_backend(backend);
            o.device = device;
            const DesignTable t = run_long(progress, [&](const Progress& p) { return design(o, p); });
            // pareto.csv's columns, and the per-band metrics as (candidates, bands) arrays.
            const std::size_t n = t.candidates.size(), bands = t.roughness_edges.size() - 1;
            py::list name, kind, storage;
            std::vector<std::uint64_t> bytes(n), fetches(n), alu(n), points(n), outside(n);
            std::vector<double> rms(n), p99(n), max_abs(n);
            std::vector<std::uint8_t> pareto(n), chosen(n), within(n);
            std::vector<double> band_rms(n * bands), band_p99(n * bands), band_max(n * bands);
            std::vector<std::uint64_t> band_points(n * bands);
            for (std::size_t i = 0; i < n; ++i) {
                const DesignCandidate& c = t.candidates[i];
                name.append(c.name);
                kind.append(c.kind);
                storage.append(c.storage);
                bytes[i] = c.bytes;
                fetches[i] = c.fetches_per_light;
                alu[i] = c.alu_per_light;
                rms[i] = c.metrics.weighted_rms;
                p99[i] = c.metrics.weighted_p99;
                max_abs[i] = c.metrics.max_abs;
                points[i] = c.metrics.points;
                pareto[i] = c.pareto;
                chosen[i] = c.chosen;
                within[i] = c.within_budget;
                outside[i] = c.outside_domain;
                for (std::size_t b = 0; b < bands; ++b) {
                    band_rms[i * bands + b] = c.by_roughness[b].weighted_rms;
                    band_p99[i * bands + b] = c.by_roughness[b].weighted_p99;
                    band_max[i * bands + b] = c.by_roughness[b].max_abs;
                    band_points[i * bands + b] = c.by_roughness[b].points;
                }
            }
            const auto np = py::module_::import("numpy");
            const auto text = [&](const py::list& l) { return np.attr("array")(l, "dtype"_a = "U"); };
            const auto flags = [&](const std::vector<std::uint8_t>& v) {
                return to_array(v, {py::ssize_t(n)}).attr("astype")("bool");
            };
            const std::vector<py::ssize_t> one{py::ssize_t(n)}, two{py::ssize_t(n), py::ssize_t(bands)};
            py::dict table;
            table["name"] = text(name);
            table["kind"] = text(kind);
            table["storage"] = text(storage);
            table["bytes"] = to_array(bytes, one);
            table["fetches_per_light"] = to_array(fetches, one);
            table["alu_per_light"] = to_array(alu, one);
            table["weighted_rms"] = to_array(rms, one);
            table["weighted_p99"] = to_array(p99, one);
            table["max_abs"] = to_array(max_abs, one);
            table["pareto"] = flags(pareto);
            table["chosen"] = flags(chosen);
            table["within_budget"] = flags(within);
            table["outside_domain"] = to_array(outside, one);
            table["points"] = to_array(points, one);
            py::dict by_roughness;
            by_roughness["edges"] = to_array(t.roughness_edges, {py::ssize_t(t.roughness_edges.size())});
            by_roughness["points"] = to_array(band_points, two);
            by_roughness["weighted_rms"] = to_array(band_rms, two);
            by_roughness["weighted_p99"] = to_array(band_p99, two);
            by_roughness["max_abs"] = to_array(band_max, two);
            py::dict reference_set;
            reference_set["file"] = t.reference_file;
            reference_set["points"] = t.reference_points;
            reference_set["max_std_error"] = t.reference_max_std_error;
            reference_set["rms_std_error"] = t.reference_rms_std_error;
            return py::make_tuple(table, by_roughness, t.chosen, reference_set);
        },
        "reference"_a, "fit_reference"_a, "cache"_a, "luts"_a, "reprs"_a, "closed_forms"_a, "fit_orders"_a, "max_bytes"_a,
        "max_fetches"_a, "max_alu"_a, "choose"_a, "analytic"_a, "strict_domain"_a, "backend"_a, "device"_a, "progress"_a);
}
