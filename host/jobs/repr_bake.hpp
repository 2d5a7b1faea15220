// The bakes of host/repr/'s representations: the term at every texel and azimuth node through the
// term integrand (jobs/eval.hpp's evaluate), and the presets baked with the exact method.
//
// Why the term integrand (one query per texel and node) and not K fixed-azimuth LUT bakes: the LUT slice
// integrand bins a whole (roughness, NdotV) slice per VNDF pass, but only on rows of constant NdotL;
// the shadow-edge warp puts every visibility column on its own NdotL values, which no row holds. The
// linear grid agrees with the fixed-azimuth LUT bake at the same nodes (tests/repr/repr_test.cpp), and
// docs/representations.md gives the measured cost of both.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "jobs/eval.hpp"
#include "repr/presets.hpp"
#include "repr/representation.hpp"
#include "schedule/cache_key.hpp"

namespace ms::repr {

// The exact method's default tolerance for a representation's reference values (the texel x node values
// it is fitted to): 1e-9, not eval's 1e-10. Near a grazing view with the light grazing on the other side
// (NdotV 0.02, NdotL <= 0.014, relative azimuth pi) the normals both see are a sliver (hemisphere measure
// ~1e-3) computed as a difference of arcs of order one, so double rounding alone bounds those values at
// ~1e-10-2.5e-10 (measured: 8 of the full-range preset's 589,824 values); a representation's own fit error
// is ~1e-3, a million times larger. `--tolerance` still asks for any other.
inline constexpr double kReferenceTolerance = 1e-9;

// Bakes the term at every texel and node: one query per (roughness, node, texel), the provable zeros
// and v = 1 answered exactly. std::invalid_argument for a spec out of range.
AzimuthBake bake_azimuth(const AzimuthBakeSpec& spec, TermBackend& backend,
                         const std::function<void(std::size_t, std::size_t)>& progress = {});

// Bakes a preset with the exact method (its default tolerance) on `backend` and builds it; the bake's
// metadata records the preset's name and domain.
std::unique_ptr<Representation> bake_preset(const Preset& p, TermBackend& backend, const std::string& command_line,
                                            const std::function<void(std::size_t, std::size_t)>& progress = {});

// A preset's representation from its bake (build_representation, and for the anisotropic preset's
// "anisotropic-corrected-harmonics" the correction's least-squares fit to the exact term at
// p.correction_queries random anisotropic queries of its domain, evaluated on `backend`).
std::unique_ptr<Representation> build_preset(const Preset& p, const AzimuthBake& bake, TermBackend& backend);

// A preset baked once per process and name on this machine's CPU with the exact method (a few seconds;
// the same texels every time), for the comparators that name one. Thread-safe.
std::shared_ptr<const Representation> baked_preset(const std::string& name);

// The cache key of a representation bake (schedule/cache_key.hpp): everything that decides its
// texels (the grid, the azimuth nodes, the sampling plan, the term, the kernels' build, the kind of
// device, the version), not the representation built from them; the fields left out, each with the
// reason: repr_cache_key_exclusions(). Its chunk store holds one item per roughness node.
schedule::CacheKey repr_cache_key(const AzimuthBakeSpec& spec, TermBackend& backend);
const std::vector<std::string>& repr_cache_key_exclusions();

}  // namespace ms::repr
