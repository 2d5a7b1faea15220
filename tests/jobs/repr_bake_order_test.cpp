// repr bake by the exact method evaluates a texel's azimuth nodes next to each other (so that the exact
// evaluator's rows share a batch) and puts each value back at its texel and node: every stored value is
// the term of that texel's own parameters (under warps that make visibility and NdotL depend on the
// roughness node and NdotV), within the recorded estimate plus the float rounding.
#include <gtest/gtest.h>

#include <cmath>

#include "exact/exact_term.hpp"
#include "jobs/eval.hpp"
#include "jobs/repr_bake.hpp"

namespace ms {
namespace {

TEST(ReprBakeOrder, ExactValuesLandOnTheirTexelsAndNodes) {
    repr::AzimuthBakeSpec spec;
    repr::ReprGrid& g = spec.grid;
    g.visibility = 4, g.n_dot_l = 3, g.n_dot_v = 3;
    g.roughness = {0.3, 0.6};
    g.warps.visibility = repr::VisibilityWarp::edge_roughness;
    g.warps.n_dot_l = repr::NdotLWarp::edge_roughness;
    g.edge_width = 1.0;
    g.n_dot_l_edge_view = 1;
    g.azimuth_warp = 2;
    spec.azimuth_nodes = 5;
    spec.plan.method = Method::exact;
    spec.plan.tolerance = 1e-9;
    spec.term.ao_weighting = g.weighting;
    const auto backend = make_oracle_backend(2);
    const repr::AzimuthBake bake = repr::bake_azimuth(spec, *backend);
    ASSERT_EQ(bake.value.size(), 2u * 5 * 3 * 3 * 4);
    int nonzero = 0;
    for (std::uint32_t r = 0; r < 2; ++r)
        for (std::uint32_t k = 0; k < spec.azimuth_nodes; ++k)
            for (std::uint32_t ivv = 0; ivv < g.n_dot_v; ++ivv)
                for (std::uint32_t il = 0; il < g.n_dot_l; ++il)
                    for (std::uint32_t iv = 0; iv < g.visibility; ++iv) {
                        const double nv = g.n_dot_v_at(ivv), nl = g.n_dot_l_at(iv, il, r, nv);
                        const double phi = g.azimuth_node(k, spec.azimuth_nodes, nv, nl);
                        const double alpha = g.roughness[r] * g.roughness[r];
                        const exact::ExactValue want =
                            exact::exact_term_at_azimuth(g.visibility_at(iv, r, nv), alpha, nv, nl, phi, g.weighting, 1e-12);
                        const std::size_t i = bake.index(r, k, iv, il, ivv);
                        // float storage: half an ulp of a value below 1 is at most 2^-25.
                        EXPECT_LE(std::fabs(double(bake.value[i]) - want.term),
                                  double(bake.std_error[i]) + want.error + 0x1p-25)
                            << "roughness " << r << " node " << k << " NdotV " << ivv << " NdotL " << il << " v " << iv;
                        nonzero += want.term > 1e-3 && want.term < 0.999;
                    }
    // Enough texels inside (0, 1) that a misplaced node or texel shows.
    EXPECT_GT(nonzero, 100);
}

}  // namespace
}  // namespace ms
