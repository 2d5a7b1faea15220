#include "jobs/sweep/spec.hpp"

#include "grid/axis.hpp"

#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "io/csv.hpp"
#include "io/input_file.hpp"
#include "io/text.hpp"

namespace ms::sweep {

namespace {

[[noreturn]] void fail(const Spec& spec, const std::string& key, const std::string& what) {
    throw SpecError(spec.source + ": " + key + ": " + what);
}

void reject_unknown_keys(const Spec& spec, const toml::table& table, const std::string& prefix,
                         const std::set<std::string>& known) {
    for (const auto& [k, v] : table) {
        const std::string key(k.str());
        if (!known.count(key)) {
            std::string list;
            for (const auto& n : known) list += (list.empty() ? "" : ", ") + n;
            fail(spec, prefix + key, "unknown key (known here: " + list + ")");
        }
    }
}

const toml::table* subtable(const Spec& spec, const toml::table& root, const std::string& key) {
    const toml::node* n = root.get(key);
    if (!n) return nullptr;
    if (!n->is_table()) fail(spec, key, "must be a table ([" + key + "])");
    return n->as_table();
}

double number(const Spec& spec, const toml::node& n, const std::string& key) {
    if (n.is_integer()) return double(n.as_integer()->get());
    if (n.is_floating_point()) {
        const double v = n.as_floating_point()->get();
        if (!std::isfinite(v)) fail(spec, key, "must be a finite number");
        return v;
    }
    fail(spec, key, "must be a number");
}

std::uint64_t positive_integer(const Spec& spec, const toml::node& n, const std::string& key, std::uint64_t max) {
    if (!n.is_integer()) fail(spec, key, "must be an integer");
    const std::int64_t v = n.as_integer()->get();
    if (v <= 0) fail(spec, key, "must be positive (got " + std::to_string(v) + ")");
    if (std::uint64_t(v) > max) fail(spec, key, "too large (" + std::to_string(v) + " > " + std::to_string(max) + ")");
    return std::uint64_t(v);
}

std::string string_value(const Spec& spec, const toml::node& n, const std::string& key) {
    if (!n.is_string()) fail(spec, key, "must be a string");
    return n.as_string()->get();
}

// Any single parameter axis may hold at most this many values; larger grids are typos.
constexpr std::uint64_t kMaxAxisCount = 10'000'000;

// A number, a list of numbers or a range table.
std::vector<double> numeric_axis(const Spec& spec, const toml::node& n, const std::string& key) {
    std::vector<double> values;
    if (n.is_number()) {
        values.push_back(number(spec, n, key));
    } else if (n.is_array()) {
        const auto& arr = *n.as_array();
        if (arr.empty()) fail(spec, key, "the list is empty");
        for (std::size_t i = 0; i < arr.size(); ++i)
            values.push_back(number(spec, *arr.get(i), key + "[" + std::to_string(i) + "]"));
    } else if (n.is_table()) {
        const auto& t = *n.as_table();
        reject_unknown_keys(spec, t, key + ".", {"start", "stop", "count", "scale"});
        Range r;
        for (const char* required : {"start", "stop", "count"})
            if (!t.get(required)) fail(spec, key, std::string("range needs '") + required + "'");
        r.start = number(spec, *t.get("start"), key + ".start");
        r.stop = number(spec, *t.get("stop"), key + ".stop");
        const toml::node& c = *t.get("count");
        if (!c.is_integer()) fail(spec, key + ".count", "must be an integer");
        if (c.as_integer()->get() <= 0)
            fail(spec, key + ".count", "must be positive (got " + std::to_string(c.as_integer()->get()) + ")");
        r.count = positive_integer(spec, c, key + ".count", kMaxAxisCount);
        if (const toml::node* s = t.get("scale")) {
            const std::string scale = string_value(spec, *s, key + ".scale");
            if (scale == "linear") r.scale = Scale::linear;
            else if (scale == "log") r.scale = Scale::log;
            else fail(spec, key + ".scale", "must be \"linear\" or \"log\" (got \"" + scale + "\")");
        }
        try {
            values = generate_range(r, key);
        } catch (const SpecError& e) {
            throw SpecError(spec.source + ": " + e.what());
        }
    } else {
        fail(spec, key, "must be a number, a list of numbers or a range table {start, stop, count}");
    }
    if (values.size() > kMaxAxisCount) fail(spec, key, "more than " + std::to_string(kMaxAxisCount) + " values");
    return values;
}

void check_interval(const Spec& spec, const std::vector<double>& values, const std::string& key, double lo,
                    bool lo_open, double hi, const std::string& interval) {
    for (double v : values)
        if (v > hi || v < lo || (lo_open && v == lo))
            fail(spec, key, "value " + format_number(v) + " outside " + interval);
}

std::vector<std::string> string_axis(const Spec& spec, const toml::node& n, const std::string& key) {
    std::vector<std::string> out;
    if (n.is_string()) {
        out.push_back(n.as_string()->get());
    } else if (n.is_array()) {
        const auto& arr = *n.as_array();
        if (arr.empty()) fail(spec, key, "the list is empty");
        for (std::size_t i = 0; i < arr.size(); ++i)
            out.push_back(string_value(spec, *arr.get(i), key + "[" + std::to_string(i) + "]"));
    } else {
        fail(spec, key, "must be a string or a list of strings");
    }
    return out;
}

// Every analytic comparator must be defined on every point of the grid, checked here rather than at
// the first bad point of a long run. From host/analytic/part1_terms.*, for the axes' own ranges
// (visibility, NdotL in [0, 1], NdotV in (0, 1]): reference-step, naughty-dog, naughty-dog-ao-fresnel,
// activision (guarded at v = 1) and pz-analytic (guarded at v = 0 and 1) are finite everywhere;
// activision-adjusted maps the point's isotropic alpha (roughness^2, or sqrt(alpha_x alpha_y): see
// points.cpp and runner.cpp) through activision_roughness_from_alpha, defined for alpha in
// (0, sqrt(2)) and finite only while 2 / alpha^2 does not overflow. The mapping is monotonic, so the
// smallest and largest alpha of the grid decide.
void check_comparator_domains(const Spec& spec) {
    if (std::find(spec.analytic.begin(), spec.analytic.end(), analytic::AnalyticTerm::activision_adjusted) ==
        spec.analytic.end())
        return;
    double lo = 0, hi = 0;
    if (spec.by_roughness) {
        const auto [mn, mx] = std::minmax_element(spec.roughness.begin(), spec.roughness.end());
        lo = *mn * *mn;
        hi = *mx * *mx;
    } else {
        const auto [xn, xx] = std::minmax_element(spec.alpha_x.begin(), spec.alpha_x.end());
        const auto [yn, yx] = std::minmax_element(spec.alpha_y.begin(), spec.alpha_y.end());
        // The same expression as the runner's: roughness = sqrt(sqrt(ax ay)), alpha = roughness^2.
        const double rl = std::sqrt(std::sqrt(*xn * *yn)), rh = std::sqrt(std::sqrt(*xx * *yx));
        lo = rl * rl;
        hi = rh * rh;
    }
    for (double alpha : {lo, hi}) {
        bool ok = alpha > 0 && alpha < std::sqrt(2.0);
        if (ok) {
            try {
                ok = std::isfinite(analytic::activision_roughness_from_alpha(alpha));
            } catch (const std::domain_error&) {
                ok = false;
            }
        }
        if (!ok)
            fail(spec, "comparators.analytic",
                 "activision-adjusted needs an isotropic alpha in (0, sqrt(2)) whose Activision roughness is finite "
                 "(alpha >= about 1e-154); the sweep reaches alpha = " + format_number(alpha) +
                     (spec.by_roughness ? " (roughness^2)" : " (sqrt(alpha_x alpha_y))"));
    }
}

std::string canonical_values(const std::vector<double>& v) {
    std::string s = "[";
    for (std::size_t i = 0; i < v.size(); ++i) s += (i ? "," : "") + format_number(v[i]);
    return s + "]";
}

}  // namespace

std::vector<double> generate_range(const Range& r, const std::string& key) {
    if (r.count == 0) throw SpecError(key + ": count must be positive");
    if (!std::isfinite(r.start) || !std::isfinite(r.stop)) throw SpecError(key + ": start and stop must be finite");
    if (r.count > 1 && r.start == r.stop)
        throw SpecError(key + ": zero-length range (start == stop) with count " + std::to_string(r.count) +
                        "; use a single value or count = 1");
    if (r.scale == Scale::log && (r.start <= 0 || r.stop <= 0))
        throw SpecError(key + ": a log range needs start > 0 and stop > 0");
    if (r.count > kMaxAxisCount) throw SpecError(key + ": more than " + std::to_string(kMaxAxisCount) + " values");
    // The values are an Axis's samples with the endpoints convention (grid/axis.hpp: both ends exact,
    // the lerp (1 - t) a + t b, log spacing pinned at the ends), the one axis type bakes and lookups use.
    Axis axis;
    axis.name = key;
    axis.min = r.start;
    axis.max = r.stop;
    axis.count = std::uint32_t(r.count);
    axis.texel = TexelConvention::endpoints;
    axis.spacing = r.scale == Scale::log ? Spacing::log : Spacing::linear;
    return axis.values();
}

Spec parse_spec(const std::string& text, const std::string& source_name, const std::string& base_dir) {
    Spec spec;
    spec.source = source_name;
    toml::table root;
    try {
        root = toml::parse(text, source_name);
    } catch (const toml::parse_error& e) {
        std::ostringstream m;
        m << source_name << ":" << e.source().begin.line << ":" << e.source().begin.column << ": TOML syntax: "
          << e.description();
        throw SpecError(m.str());
    }
    reject_unknown_keys(spec, root, "", {"sweep", "sampling", "parameters", "comparators"});

    if (const auto* t = subtable(spec, root, "sweep")) {
        reject_unknown_keys(spec, *t, "sweep.", {"name", "chunk_size", "max_points"});
        if (const auto* n = t->get("name")) spec.name = string_value(spec, *n, "sweep.name");
        if (const auto* n = t->get("chunk_size")) spec.chunk_size = positive_integer(spec, *n, "sweep.chunk_size", 1 << 22);
        if (const auto* n = t->get("max_points"))
            spec.max_points = positive_integer(spec, *n, "sweep.max_points", kHardMaxPoints);
    }
    if (const auto* t = subtable(spec, root, "sampling")) {
        reject_unknown_keys(spec, *t, "sampling.", {"samples", "replicates", "seed", "sequence", "method", "tolerance"});
        if (const auto* n = t->get("samples")) spec.samples = positive_integer(spec, *n, "sampling.samples", 1ULL << 34);
        if (const auto* n = t->get("replicates")) {
            spec.replicates = std::uint32_t(positive_integer(spec, *n, "sampling.replicates", 1024));
            if (*spec.replicates < 2) fail(spec, "sampling.replicates", "needs at least 2 (for the error estimate)");
        }
        if (const auto* n = t->get("seed")) {
            if (!n->is_integer() || n->as_integer()->get() < 0) fail(spec, "sampling.seed", "must be an integer >= 0");
            spec.seed = std::uint64_t(n->as_integer()->get());
        }
        if (const auto* n = t->get("sequence")) {
            spec.sequence = string_value(spec, *n, "sampling.sequence");
            try {
                parse_sequence(*spec.sequence);
            } catch (const std::invalid_argument& e) {
                fail(spec, "sampling.sequence", e.what());
            }
        }
        if (const auto* n = t->get("method")) {
            const std::string text = string_value(spec, *n, "sampling.method");
            if (text != "exact" && text != "sampled") fail(spec, "sampling.method", "must be \"exact\" or \"sampled\"");
            spec.method = parse_method(text);
        }
        if (const auto* n = t->get("tolerance")) {
            const auto value = n->value<double>();
            // The exact evaluator's range (integrands/exact_term/): below 1e-13 rounding dominates.
            if (!value || !(*value >= 1e-13 && *value <= 0.1))
                fail(spec, "sampling.tolerance", "must be a number in [1e-13, 0.1]");
            spec.tolerance = *value;
        }
    }

    const auto* params = subtable(spec, root, "parameters");
    if (!params) fail(spec, "parameters", "missing (the [parameters] table is required)");
    reject_unknown_keys(spec, *params, "parameters.",
                        {"visibility", "n_dot_l", "n_dot_v", "roughness", "alpha_x", "alpha_y", "phi_i", "phi_o",
                         "delta_phi", "form", "ao_weighting"});
    auto axis = [&](const char* name, bool required, std::vector<double> fallback) {
        const std::string key = std::string("parameters.") + name;
        if (const auto* n = params->get(name)) return numeric_axis(spec, *n, key);
        if (required) fail(spec, key, "required");
        return fallback;
    };
    spec.visibility = axis("visibility", true, {});
    check_interval(spec, spec.visibility, "parameters.visibility", 0, false, 1, "[0, 1]");
    spec.n_dot_l = axis("n_dot_l", true, {});
    check_interval(spec, spec.n_dot_l, "parameters.n_dot_l", 0, false, 1, "[0, 1]");
    spec.n_dot_v = axis("n_dot_v", false, {1.0});
    check_interval(spec, spec.n_dot_v, "parameters.n_dot_v", 0, true, 1, "(0, 1] (the view must be above the horizon)");

    const bool has_r = params->get("roughness"), has_ax = params->get("alpha_x"), has_ay = params->get("alpha_y");
    if (has_r && (has_ax || has_ay)) fail(spec, "parameters.roughness", "give either roughness or alpha_x and alpha_y, not both");
    if (has_r) {
        spec.by_roughness = true;
        spec.roughness = axis("roughness", true, {});
        check_interval(spec, spec.roughness, "parameters.roughness", 0, true, 1, "(0, 1]");
        // alpha = roughness^2 must not underflow to 0 (the term needs alpha > 0: a run would stop
        // part-way at the first such point).
        for (double r : spec.roughness)
            if (!(r * r > 0))
                fail(spec, "parameters.roughness", "value " + format_number(r) + " is too small: alpha = roughness^2 underflows to 0");
    } else if (has_ax || has_ay) {
        if (!has_ax || !has_ay) fail(spec, has_ax ? "parameters.alpha_y" : "parameters.alpha_x", "required with the other alpha");
        spec.by_roughness = false;
        spec.alpha_x = axis("alpha_x", true, {});
        spec.alpha_y = axis("alpha_y", true, {});
        check_interval(spec, spec.alpha_x, "parameters.alpha_x", 0, true, 1e6, "(0, 1e6]");
        check_interval(spec, spec.alpha_y, "parameters.alpha_y", 0, true, 1e6, "(0, 1e6]");
    } else {
        fail(spec, "parameters.roughness", "required (or alpha_x and alpha_y)");
    }

    spec.phi_i = axis("phi_i", false, {0.0});
    if (params->get("phi_o") && params->get("delta_phi"))
        fail(spec, "parameters.phi_o", "give either phi_o or delta_phi, not both");
    spec.relative_azimuth = !params->get("phi_o");
    spec.phi_o_or_delta = spec.relative_azimuth ? axis("delta_phi", false, {0.0}) : axis("phi_o", true, {});
    for (const auto* key : {"phi_i", "phi_o", "delta_phi"})
        if (params->get(key))
            check_interval(spec, std::string(key) == "phi_i" ? spec.phi_i : spec.phi_o_or_delta,
                           std::string("parameters.") + key, -720, false, 720, "[-720, 720] degrees");

    if (const auto* n = params->get("form"))
        for (const auto& s : string_axis(spec, *n, "parameters.form")) {
            try {
                spec.forms.push_back(parse_form(s));
            } catch (const std::invalid_argument& e) {
                fail(spec, "parameters.form", e.what());
            }
        }
    if (const auto* n = params->get("ao_weighting"))
        for (const auto& s : string_axis(spec, *n, "parameters.ao_weighting")) {
            try {
                spec.weightings.push_back(parse_ao_weighting(s));
            } catch (const std::invalid_argument& e) {
                fail(spec, "parameters.ao_weighting", e.what());
            }
        }

    if (const auto* t = subtable(spec, root, "comparators")) {
        reject_unknown_keys(spec, *t, "comparators.", {"analytic", "lut"});
        if (const auto* n = t->get("analytic"))
            for (const auto& s : string_axis(spec, *n, "comparators.analytic")) {
                try {
                    spec.analytic.push_back(analytic::parse_analytic_term(s));
                } catch (const std::invalid_argument& e) {
                    fail(spec, "comparators.analytic", e.what());
                }
            }
        if (const auto* n = t->get("lut")) {
            if (!n->is_array_of_tables()) fail(spec, "comparators.lut", "must be an array of tables ([[comparators.lut]])");
            const auto& arr = *n->as_array();
            for (std::size_t i = 0; i < arr.size(); ++i) {
                const std::string key = "comparators.lut[" + std::to_string(i) + "]";
                const auto& lt = *arr.get(i)->as_table();
                reject_unknown_keys(spec, lt, key + ".", {"name", "file", "preset"});
                if (!lt.get("name")) fail(spec, key + ".name", "required");
                if (!lt.get("file") == !lt.get("preset")) fail(spec, key + ".file", "give file or preset (a representation preset's name), one of them");
                LutComparatorSpec l;
                l.name = string_value(spec, *lt.get("name"), key + ".name");
                if (lt.get("preset")) {
                    l.preset = string_value(spec, *lt.get("preset"), key + ".preset");
                } else {
                    const std::string file = string_value(spec, *lt.get("file"), key + ".file");
                    const std::filesystem::path p(file);
                    l.file = p.is_absolute() ? file : (std::filesystem::path(base_dir) / p).lexically_normal().string();
                }
                if (l.name.empty() || l.name.find_first_of(",\"\n\r ") != std::string::npos)
                    fail(spec, key + ".name", "must be non-empty, without commas, quotes or spaces (it is a CSV column)");
                // TOML strings may hold escapes such as \u0001 or \t: a control character in a column
                // name corrupts the CSV header and the terminal output of the summary.
                for (unsigned char c : l.name)
                    if (c < 0x20 || c == 0x7F) {
                        char code[8];
                        std::snprintf(code, sizeof code, "0x%02X", c);
                        fail(spec, key + ".name", std::string("must not contain control characters (found ") + code + ")");
                    }
                spec.luts.push_back(l);
            }
        }
    }
    // Column names must be unique and must not shadow the fixed columns.
    std::set<std::string> seen = {"point", "form", "ao_weighting", "roughness", "alpha_x", "alpha_y", "n_dot_v",
                                  "phi_i", "phi_o", "delta_phi", "n_dot_l", "visibility", "term", "std_error"};
    for (const auto& name : comparator_names(spec))
        if (!seen.insert(name).second) fail(spec, "comparators", "duplicate or reserved column name '" + name + "'");

    check_comparator_domains(spec);

    // Size check in uint64 with overflow detection: the product of axis sizes must stay below the
    // limit (a long double product printed through llround gave "-9223372036854775808 points").
    std::uint64_t total = 1;
    bool overflow = false;
    std::uint64_t alpha_pairs = spec.roughness.size();
    if (!spec.by_roughness) overflow |= __builtin_mul_overflow(std::uint64_t(spec.alpha_x.size()), std::uint64_t(spec.alpha_y.size()), &alpha_pairs);
    for (std::uint64_t n : {std::uint64_t(spec.visibility.size()), std::uint64_t(spec.n_dot_l.size()),
                            std::uint64_t(spec.n_dot_v.size()), alpha_pairs, std::uint64_t(spec.phi_i.size()),
                            std::uint64_t(spec.phi_o_or_delta.size()), std::uint64_t(std::max<std::size_t>(1, spec.forms.size())),
                            std::uint64_t(std::max<std::size_t>(1, spec.weightings.size()))})
        overflow |= __builtin_mul_overflow(total, n, &total);
    if (overflow || total > spec.max_points) {
        std::ostringstream m;
        m << "the sweep has " << (overflow ? "more than 2^64" : std::to_string(total)) << " points, more than the limit of "
          << spec.max_points
          << (root["sweep"]["max_points"] ? " set by sweep.max_points" : "; set [sweep] max_points to run it anyway");
        fail(spec, "parameters", m.str());
    }
    return spec;
}

Spec parse_spec_file(const std::string& path) {
    // Bounded read: a regular file (or pipe) of at most kMaxSpecBytes; /dev/zero ended in bad_alloc.
    std::string text;
    try {
        text = read_input_file(path, kMaxSpecBytes, "sweep spec");
    } catch (const InputError& e) {
        throw SpecError(e.what());
    }
    const auto dir = std::filesystem::path(path).parent_path();
    // The name is recorded in messages and in the manifest (JSON): invalid UTF-8 bytes as \xHH.
    return parse_spec(text, json_safe(path), dir.empty() ? "." : dir.string());
}

std::vector<std::string> comparator_names(const Spec& spec) {
    std::vector<std::string> names;
    for (auto t : spec.analytic) names.push_back(analytic::to_string(t));
    for (const auto& l : spec.luts) names.push_back(l.name);
    return names;
}

std::string canonical_text(const Spec& spec) {
    std::ostringstream s;
    s << "visibility=" << canonical_values(spec.visibility) << "\nn_dot_l=" << canonical_values(spec.n_dot_l)
      << "\nn_dot_v=" << canonical_values(spec.n_dot_v);
    if (spec.by_roughness) s << "\nroughness=" << canonical_values(spec.roughness);
    else s << "\nalpha_x=" << canonical_values(spec.alpha_x) << "\nalpha_y=" << canonical_values(spec.alpha_y);
    s << "\nphi_i=" << canonical_values(spec.phi_i) << (spec.relative_azimuth ? "\ndelta_phi=" : "\nphi_o=")
      << canonical_values(spec.phi_o_or_delta) << "\nform=";
    for (auto f : spec.forms) s << to_string(f) << ";";
    s << "\nao_weighting=";
    for (auto w : spec.weightings) s << to_string(w) << ";";
    s << "\ncomparators=";
    for (const auto& n : comparator_names(spec)) s << n << ";";
    s << "\nchunk_size=" << spec.chunk_size << "\n";
    return s.str();
}

}  // namespace ms::sweep
