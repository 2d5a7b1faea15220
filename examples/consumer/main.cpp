// Evaluates the micro-shadowing term on a few queries and bakes a small LUT through microshadow's
// public API, then checks what it got. Exit status 0 when every check passes.
//   consumer [OUT_DIR]   (writes OUT_DIR/consumer-lut.ktx2; default: the current directory)
#include <microshadow/microshadow.hpp>

#include <cmath>
#include <cstdio>
#include <exception>
#include <string>

namespace {

int failures = 0;

void check(bool ok, const std::string& what) {
    if (!ok) {
        std::fprintf(stderr, "consumer: FAILED: %s\n", what.c_str());
        ++failures;
    }
}

}  // namespace

int main(int argc, char** argv) {
    const std::string out_dir = argc > 1 ? argv[1] : ".";
    try {
        // The oracle backend needs no OpenCL device: the same numbers on any machine.
        microshadow::SamplingOptions sampling;
        sampling.method = microshadow::Method::sampled;  // evaluate's default is exact; this shows the error bars
        sampling.backend = microshadow::Backend::oracle;
        sampling.samples = 4096;

        microshadow::Query open_sky;  // visibility 1: nothing occludes, exactly 1
        microshadow::Query grazing;   // a grazing light under a half-closed cone
        grazing.visibility = 0.5;
        grazing.alpha_x = grazing.alpha_y = 0.3;
        grazing.wi = {0.6, 0, 0.8};
        grazing.wo = {-0.9165151, 0, 0.4};
        const auto estimates = microshadow::evaluate({open_sky, grazing}, sampling);
        check(estimates.size() == 2, "two estimates");
        check(estimates[0].value == 1 && estimates[0].std_error == 0, "visibility 1 gives exactly 1");
        check(estimates[1].value > 0 && estimates[1].value < 1, "a partly shadowed query is in (0, 1)");
        check(estimates[1].std_error > 0 && estimates[1].std_error < 0.05, "its standard error is small and not 0");
        std::printf("term at the grazing query: %.6f +- %.6f\n", estimates[1].value, estimates[1].std_error);

        microshadow::BakeOptions bake;
        bake.layout = "custom";
        bake.visibility_count = 6;
        bake.n_dot_l_count = 4;
        bake.n_dot_v_count = 2;
        bake.roughness = {0.3, 0.8};
        bake.sampling = sampling;
        bake.sampling.samples = 1024;
        const microshadow::Lut lut = microshadow::bake(bake);
        check(lut.visibility_count() == 6 && lut.n_dot_l_count() == 4 && lut.n_dot_v_count() == 2, "the LUT has the asked size");
        check(lut.roughness().size() == 2, "two roughness channels");
        bool in_range = true;
        for (std::uint32_t c = 0; c < 2; ++c)
            for (std::uint32_t z = 0; z < 2; ++z)
                for (std::uint32_t y = 0; y < 4; ++y)
                    for (std::uint32_t x = 0; x < 6; ++x) {
                        const float t = lut.texel(c, x, y, z);
                        in_range = in_range && t >= 0 && t <= 1;
                    }
        check(in_range, "every texel is in [0, 1]");
        check(lut.max_total_error() > 0, "the LUT records its error bound");
        // At a texel centre the renderer's lookup returns the texel itself (texel centres at (i + 0.5) / n).
        const double v = (2 + 0.5) / 6, l = (3 + 0.5) / 4, nv = (1 + 0.5) / 2;
        check(std::abs(lut.lookup(v, l, nv, microshadow::Roughness(0.8)) - lut.texel(1, 2, 3, 1)) < 1e-6, "lookup at a texel centre is the texel");

        const std::string path = out_dir + "/consumer-lut.ktx2";
        lut.save(path);
        const microshadow::Lut back = microshadow::open_lut(path);
        bool same = true;
        for (std::uint32_t x = 0; x < 6; ++x) same = same && back.texel(0, x, 1, 0) == lut.texel(0, x, 1, 0);
        check(same, "the saved KTX2 reads back with the same float32 texels");
        std::printf("microshadow %s: baked and reread a %ux%ux%u LUT (max total error %.3g)\n", microshadow::version().c_str(),
                    lut.visibility_count(), lut.n_dot_l_count(), lut.n_dot_v_count(), lut.max_total_error());
    } catch (const std::exception& e) {
        std::fprintf(stderr, "consumer: error: %s\n", e.what());
        return 1;
    }
    return failures == 0 ? 0 : 1;
}
