// microshadow::sweep: `microshadow sweep` (cli/cmd_sweep.cpp) as a call; the run goes through the same
// runner (chunks, manifest, sweep.csv), and sweep.csv is read back as columns.
#include "microshadow/sweep.hpp"

#include <charconv>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>

#include "api/facade.hpp"
#include "exact/exact_term.hpp"
#include "integrands/exact_term/exact_term_integrand.hpp"
#include "jobs/sweep/runner.hpp"
#include "jobs/sweep/spec.hpp"
#include "repr/representation.hpp"
#include "sampling/point_set.hpp"

namespace microshadow {

namespace {

namespace fs = std::filesystem;

// A fresh directory under the system's temporary directory, removed when this goes out of scope.
class TemporaryDirectory {
public:
    TemporaryDirectory() {
        std::random_device device;
        for (int attempt = 0; attempt < 100; ++attempt) {
            const fs::path candidate = fs::temp_directory_path() / ("microshadow-sweep-" + std::to_string(device()));
            if (fs::create_directory(candidate)) {
                path_ = candidate;
                return;
            }
        }
        throw std::runtime_error("microshadow::sweep: could not make a temporary directory in " +
                                 fs::temp_directory_path().string());
    }
    ~TemporaryDirectory() {
        std::error_code ignored;
        fs::remove_all(path_, ignored);
    }
    const fs::path& path() const { return path_; }

private:
    fs::path path_;
};

std::vector<std::string> split_fields(const std::string& line) {
    std::vector<std::string> fields;
    std::string field;
    std::istringstream in(line);
    while (std::getline(in, field, ',')) fields.push_back(field);
    if (!line.empty() && line.back() == ',') fields.emplace_back();
    return fields;
}

// sweep.csv (the runner's own output: a header, then one row a point) as columns.
SweepTable read_sweep_csv(const fs::path& path) {
    std::ifstream in(path);
    if (!in) throw std::runtime_error("microshadow::sweep: cannot read " + path.string());
    SweepTable table;
    std::string line;
    if (!std::getline(in, line)) throw std::runtime_error("microshadow::sweep: " + path.string() + " is empty");
    table.columns = split_fields(line);
    const std::size_t n = table.columns.size();
    table.numbers.resize(n);
    table.texts.resize(n);
    std::vector<bool> is_text(n, false);
    for (std::size_t k = 0; k < n; ++k) is_text[k] = table.columns[k] == "form" || table.columns[k] == "ao_weighting";
    std::size_t row = 0;
    while (std::getline(in, line)) {
        if (line.empty()) continue;
        ++row;
        const std::vector<std::string> fields = split_fields(line);
        if (fields.size() != n)
            throw std::runtime_error("microshadow::sweep: " + path.string() + ": row " + std::to_string(row) + " has " +
                                     std::to_string(fields.size()) + " fields, not " + std::to_string(n));
        for (std::size_t k = 0; k < n; ++k) {
            if (is_text[k]) {
                table.texts[k].push_back(fields[k]);
                continue;
            }
            // strtod reads what format_number writes, "nan" and "inf" included.
            char* end = nullptr;
            const double v = std::strtod(fields[k].c_str(), &end);
            if (fields[k].empty() || *end != '\0')
                throw std::runtime_error("microshadow::sweep: " + path.string() + ": row " + std::to_string(row) +
                                         ", column " + table.columns[k] + ": '" + fields[k] + "' is not a number");
            table.numbers[k].push_back(v);
        }
    }
    return table;
}

SweepTable run(ms::sweep::Spec spec, const SweepOptions& o, const Progress& progress) {
    // The plan as the CLI builds it: the spec's [sampling] values unless the option is given.
    ms::SamplingPlan plan;
    plan.method = o.method ? (*o.method == Method::exact ? ms::Method::exact : ms::Method::sampled)
                           : spec.method.value_or(ms::Method::exact);
    plan.tolerance = o.tolerance ? *o.tolerance : spec.tolerance.value_or(0.0);
    const std::uint32_t replicates = o.replicates ? *o.replicates : spec.replicates.value_or(8u);
    const std::uint64_t samples = o.samples ? *o.samples : spec.samples.value_or(65536u);
    plan.replicates = replicates;
    plan.samples = ms::round_up_samples(samples, replicates);
    plan.seed = o.seed ? *o.seed : spec.seed.value_or(0u);
    if (o.sequence) plan.sequence = detail::to_ms(*o.sequence);
    else if (spec.sequence) plan.sequence = ms::parse_sequence(*spec.sequence);
    plan.single_precision = o.exact_float;
    if (plan.method == ms::Method::sampled && plan.tolerance > 0)
        throw std::invalid_argument("microshadow::sweep: tolerance applies to the exact method; a sampled sweep takes samples");
    if (plan.method == ms::Method::exact) {
        if (plan.tolerance == 0) plan.tolerance = ms::exact::kDefaultTolerance;
        ms::exact_term::validate_tolerance(plan.tolerance);
    } else if (replicates < 2) {
        throw std::invalid_argument("microshadow::sweep: replicates = " + std::to_string(replicates) + " (at least 2)");
    }
    if (!spec.forms.empty() && o.form)
        throw std::invalid_argument("microshadow::sweep: form conflicts with parameters.form in " + spec.source);
    if (!spec.weightings.empty() && o.ao_weighting)
        throw std::invalid_argument("microshadow::sweep: ao_weighting conflicts with parameters.ao_weighting in " + spec.source);
    ms::sweep::check_comparator_files(spec);

    std::optional<TemporaryDirectory> temporary;
    ms::sweep::RunConfig config;
    if (o.out.empty()) {
        temporary.emplace();
        config.out_dir = temporary->path().string();
    } else {
        config.out_dir = o.out;
    }
    config.plan = plan;
    config.defaults = detail::term_options(o.ao_weighting.value_or(AoWeighting::cosine),
                                           o.form.value_or(Form::height_correlated));
    config.command_line = "microshadow::sweep (library " MICROSHADOW_VERSION ")";
    auto backend = detail::make_backend(o.backend, o.device, o.fast_math);
    config.backend = backend.get();
    const ms::sweep::RunResult result = detail::run_with_progress(progress, [&](const auto& report) {
        config.progress = [&](std::uint64_t done, std::uint64_t total) { report(done, total); };
        return ms::sweep::run_sweep(spec, config);
    });
    if (!result.assembled) throw std::runtime_error("microshadow::sweep: the sweep did not assemble sweep.csv");
    SweepTable table = read_sweep_csv(fs::path(config.out_dir) / "sweep.csv");
    std::ifstream summary(fs::path(config.out_dir) / "summary.md");
    std::ostringstream text;
    text << summary.rdbuf();
    table.summary_markdown = text.str();
    return table;
}

}  // namespace

SweepTable sweep(const std::string& spec_path, const SweepOptions& options, const Progress& progress) {
    return run(ms::sweep::parse_spec_file(spec_path), options, progress);
}

SweepTable sweep_toml(const std::string& toml_text, const std::string& base_dir, const SweepOptions& options,
                      const Progress& progress) {
    return run(ms::sweep::parse_spec(toml_text, "the sweep spec", base_dir), options, progress);
}

}  // namespace microshadow
