// The C++ API's front end of the front-end test (python/tests/frontends.py): runs one job through the
// public API only (<microshadow/microshadow.hpp>, as a library user would) and writes what it returns.
//
//   microshadow_api_jobs eval QUERIES.bin OUT.bin [FIELD=VALUE ...]       (N, 9) float64 rows -> (N, 2)
//   microshadow_api_jobs area SURFACE.bin LIGHT.bin OUT.bin [FIELD=VALUE ...]   sphere lights -> (N, 3)
//   microshadow_api_jobs bake OUT [FIELD=VALUE ...]                        Lut::save(OUT)
//   microshadow_api_jobs repr OUT [FIELD=VALUE ...]                        LookupFile::save(OUT)
//
// Every FIELD is the options struct's field name (BakeOptions, ReprBakeOptions, SamplingOptions), the
// name the test also gives the CLI (with dashes) and Python (as a keyword): the test thereby checks that
// one name means one parameter in all three. Arrays are raw little-endian float64, row-major.
#include <microshadow/microshadow.hpp>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <fstream>
#include <iostream>
#include <iterator>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

using namespace microshadow;

namespace {

std::vector<double> read_doubles(const std::string& path, std::size_t columns) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::runtime_error(path + ": cannot open");
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (bytes.size() % (columns * sizeof(double)) != 0) throw std::runtime_error(path + ": not rows of " + std::to_string(columns));
    std::vector<double> values(bytes.size() / sizeof(double));
    for (std::size_t i = 0; i < values.size(); ++i) std::memcpy(&values[i], bytes.data() + i * sizeof(double), sizeof(double));
    return values;
}

void write_doubles(const std::string& path, const std::vector<double>& values) {
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(values.data()), std::streamsize(values.size() * sizeof(double)));
    if (!out) throw std::runtime_error(path + ": cannot write");
}

std::vector<double> numbers(const std::string& text) {
    std::vector<double> out;
    std::stringstream in(text);
    for (std::string item; std::getline(in, item, ',');) out.push_back(std::stod(item));
    return out;
}

template <class E>
E choose(const std::string& field, const std::string& text, const std::map<std::string, E>& names) {
    const auto it = names.find(text);
    if (it == names.end()) throw std::invalid_argument(field + " = " + text);
    return it->second;
}

// Sets a SamplingOptions field; false when `field` is not one.
bool set_sampling(SamplingOptions& o, const std::string& field, const std::string& value) {
    if (field == "method") o.method = choose<Method>(field, value, {{"exact", Method::exact}, {"sampled", Method::sampled}});
    else if (field == "backend") o.backend = choose<Backend>(field, value, {{"opencl", Backend::opencl}, {"oracle", Backend::oracle}});
    else if (field == "device") o.device = value;
    else if (field == "samples") o.samples = std::stoull(value);
    else if (field == "replicates") o.replicates = std::uint32_t(std::stoul(value));
    else if (field == "seed") o.seed = std::stoull(value);
    else if (field == "tolerance") o.tolerance = std::stod(value);
    else if (field == "sequence") o.sequence = choose<Sequence>(field, value, {{"sobol", Sequence::sobol}, {"random", Sequence::random}});
    else if (field == "form") o.form = choose<Form>(field, value, {{"height-correlated", Form::height_correlated}, {"uncorrelated", Form::uncorrelated}});
    else if (field == "ao_weighting") o.ao_weighting = choose<AoWeighting>(field, value, {{"cosine", AoWeighting::cosine}, {"uniform", AoWeighting::uniform}});
    else return false;
    return true;
}

std::map<std::string, std::string> fields(int argc, char** argv, int first) {
    std::map<std::string, std::string> out;
    for (int i = first; i < argc; ++i) {
        const std::string a = argv[i];
        const auto eq = a.find('=');
        if (eq == std::string::npos) throw std::invalid_argument("not FIELD=VALUE: " + a);
        out[a.substr(0, eq)] = a.substr(eq + 1);
    }
    return out;
}

int run(int argc, char** argv) {
    if (argc < 3) throw std::invalid_argument("usage: microshadow_api_jobs eval|area|bake|repr ...");
    const std::string job = argv[1];
    if (job == "eval") {
        if (argc < 4) throw std::invalid_argument("eval QUERIES.bin OUT.bin [FIELD=VALUE ...]");
        SamplingOptions o;
        for (const auto& [field, value] : fields(argc, argv, 4))
            if (!set_sampling(o, field, value)) throw std::invalid_argument("eval: no field " + field);
        const std::vector<double> rows = read_doubles(argv[2], 9);
        std::vector<Query> queries(rows.size() / 9);
        for (std::size_t i = 0; i < queries.size(); ++i) {
            const double* r = &rows[9 * i];
            queries[i] = {r[0], r[1], r[2], {r[3], r[4], r[5]}, {r[6], r[7], r[8]}};
        }
        std::vector<double> out;
        for (const Estimate& e : evaluate(queries, o)) out.insert(out.end(), {e.value, e.std_error});
        write_doubles(argv[3], out);
    } else if (job == "area") {
        if (argc < 5) throw std::invalid_argument("area SURFACE.bin LIGHT.bin OUT.bin [FIELD=VALUE ...]");
        AreaOptions o;
        for (const auto& [field, value] : fields(argc, argv, 5)) {
            if (field == "lobe") o.lobe = choose<Lobe>(field, value, {{"ggx", Lobe::ggx}, {"lambert", Lobe::lambert}});
            else if (!set_sampling(o.sampling, field, value)) throw std::invalid_argument("area: no field " + field);
        }
        const std::vector<double> surface = read_doubles(argv[2], 6), light = read_doubles(argv[3], 4);
        if (surface.size() / 6 != light.size() / 4) throw std::invalid_argument("area: surface and light rows differ");
        std::vector<AreaQuery> queries(surface.size() / 6);
        for (std::size_t i = 0; i < queries.size(); ++i) {
            const double* s = &surface[6 * i];
            const double* l = &light[4 * i];
            AreaQuery& q = queries[i];
            q.visibility = s[0];
            q.alpha_x = s[1];
            q.alpha_y = s[2];
            q.wi = {s[3], s[4], s[5]};
            q.light = LightShape::sphere;
            q.light_direction = {l[0], l[1], l[2]};
            q.half_angle_deg = l[3];
        }
        std::vector<double> out;
        for (const AreaEstimate& e : area_evaluate(queries, o)) out.insert(out.end(), {e.value, e.std_error, e.inner_error});
        write_doubles(argv[4], out);
    } else if (job == "bake") {
        BakeOptions o;
        for (const auto& [field, value] : fields(argc, argv, 3)) {
            if (field == "layout") o.layout = value;
            else if (field == "size") o.size = std::uint32_t(std::stoul(value));
            else if (field == "visibility_count") o.visibility_count = std::uint32_t(std::stoul(value));
            else if (field == "n_dot_l_count") o.n_dot_l_count = std::uint32_t(std::stoul(value));
            else if (field == "n_dot_v_count") o.n_dot_v_count = std::uint32_t(std::stoul(value));
            else if (field == "roughness") o.roughness = numbers(value);
            else if (field == "texel") o.texel = value;
            else if (field == "azimuth") o.azimuth = value;
            // The bake's tolerance is its own field (batches to a standard error), as the CLI's --tolerance.
            else if (field == "tolerance") o.tolerance = std::stod(value);
            else if (field == "max_batches") o.max_batches = std::uint32_t(std::stoul(value));
            else if (!set_sampling(o.sampling, field, value)) throw std::invalid_argument("bake: no field " + field);
        }
        bake(o).save(argv[2]);
    } else if (job == "repr") {
        ReprBakeOptions o;
        for (const auto& [field, value] : fields(argc, argv, 3)) {
            if (field == "preset") o.preset = value;
            else if (field == "kind") o.kind = value;
            else if (field == "visibility_count") o.visibility_count = std::uint32_t(std::stoul(value));
            else if (field == "n_dot_l_count") o.n_dot_l_count = std::uint32_t(std::stoul(value));
            else if (field == "n_dot_v_count") o.n_dot_v_count = std::uint32_t(std::stoul(value));
            else if (field == "azimuth_nodes") o.azimuth_nodes = std::uint32_t(std::stoul(value));
            else if (field == "roughness") o.roughness = numbers(value);
            else if (field == "roughness_count") o.roughness_count = std::uint32_t(std::stoul(value));
            else if (field == "n_dot_v_warp") o.n_dot_v_warp = value;
            else if (field == "n_dot_l_warp") o.n_dot_l_warp = value;
            else if (field == "visibility_warp") o.visibility_warp = value;
            else if (!set_sampling(o.sampling, field, value)) throw std::invalid_argument("repr: no field " + field);
        }
        repr_bake(o).save(argv[2]);
    } else {
        throw std::invalid_argument("no job " + job);
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    try {
        return run(argc, argv);
    } catch (const std::exception& e) {
        std::cerr << "microshadow_api_jobs: " << e.what() << "\n";
        return 2;
    }
}
