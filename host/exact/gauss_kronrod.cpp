#include "exact/gauss_kronrod.hpp"

#include <array>
#include <stdexcept>
#include <string>

#include "exact/gauss_legendre.hpp"

namespace ms::exact {

namespace {

// The Kronrod nodes and weights on [0, 1] (the rules are symmetric), as tabulated in the literature
// (Kronrod 1965; Piessens et al., QUADPACK, 1983; to 17 digits). Rows alternate Kronrod-only and Gauss
// nodes, starting at 0 (a Kronrod-only node for even n). GaussKronrod tests check every row: the rule
// integrates x^k exactly for k <= 3n+1 and its odd rows are gauss_legendre(n)'s nodes.
struct HalfRow {
    double node, kronrod_weight;
};
constexpr std::array<HalfRow, 9> kHalf17 = {{{0.0, 0.18444640574469165},
                                            {0.18343464249564981, 0.18140002506803463},
                                            {0.36070109792813193, 0.17207060855521125},
                                            {0.52553240991632899, 0.15665260616818844},
                                            {0.67235407094515864, 0.13626310925517218},
                                            {0.79666647741362684, 0.11164637082683958},
                                            {0.89412090684745638, 0.082482298931358361},
                                            {0.96028985649753629, 0.049439395002139182},
                                            {0.99337987588171617, 0.017822383320710337}}};
constexpr std::array<HalfRow, 13> kHalf25 = {{{0.0, 0.12555689390547436},
                                             {0.12523340851146891, 0.12458416453615601},
                                             {0.24850574832046923, 0.12162630352394838},
                                             {0.36783149899818018, 0.11671205350175685},
                                             {0.48133945047815707, 0.11002260497764406},
                                             {0.58731795428661748, 0.10164973227906031},
                                             {0.68405989547005586, 0.091549468295049202},
                                             {0.76990267419430469, 0.079920275333601715},
                                             {0.84355812416115328, 0.067250907050839956},
                                             {0.90411725637047491, 0.053697017607756255},
                                             {0.95053779594312127, 0.038915230469299525},
                                             {0.98156063424671924, 0.023036084038982212},
                                             {0.99693392252959545, 0.0082577114331683597}}};

template <std::size_t H>
struct FullRule {
    static constexpr int kPoints = int(2 * H - 1);
    double nodes[kPoints], kronrod[kPoints], gauss[kPoints];
    KronrodRule rule;

    explicit FullRule(const std::array<HalfRow, H>& half) {
        const int n = int(H - 1);
        // The Gauss weights come from the Gauss-Legendre rule itself (the odd rows hold its nodes).
        const GaussRule& g = gauss_legendre(n);
        for (int i = 0; i < kPoints; ++i) {
            const int from_centre = i - int(H - 1);  // -(H-1) .. H-1
            const HalfRow& row = half[std::size_t(from_centre < 0 ? -from_centre : from_centre)];
            nodes[i] = from_centre < 0 ? -row.node : row.node;
            kronrod[i] = row.kronrod_weight;
            // Odd index i <-> Gauss node (i - 1) / 2 in ascending order.
            gauss[i] = (i % 2 == 1) ? g.weights[std::size_t((i - 1) / 2)] : 0.0;
        }
        rule = {n, kPoints, nodes, kronrod, gauss};
    }
};

}  // namespace

const KronrodRule& gauss_kronrod(int gauss_nodes) {
    // Built on first use (thread-safe static initialisation), after gauss_legendre's own rules.
    static const FullRule<9> rule17(kHalf17);
    static const FullRule<13> rule25(kHalf25);
    if (gauss_nodes == 8) return rule17.rule;
    if (gauss_nodes == 12) return rule25.rule;
    throw std::invalid_argument("gauss_kronrod: no tabulated pair for " + std::to_string(gauss_nodes) +
                                " Gauss nodes (8 and 12 are)");
}

}  // namespace ms::exact
