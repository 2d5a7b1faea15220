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

// Bakes the term at every texel and node: one query per (roughness, node, texel), the provable zeros
// and v = 1 answered exactly. std::invalid_argument for a spec out of range.
AzimuthBake bake_azimuth(const AzimuthBakeSpec& spec, TermBackend& backend,
                         const std::function<void(std::size_t, std::size_t)>& progress = {});

// Bakes the anisotropic term's representation (AnisotropicBakeSpec, repr/anisotropic.cpp): per slab
// of projected-roughness nodes (view, light) the term of surfaces at every (dphi, rho) configuration
// and texel, and the least-squares series fitted to them. The metadata records preset_name (when not
// empty) and `domain` (without one: the nodes' roughness per axis, ratio <= spec.max_ratio).
// std::invalid_argument for a spec out of range. No command, preset or library call bakes this kind
// (the anisotropic preset is anisotropic-corrected-harmonics, baked by bake_preset): it is kept with the
// kind itself (repr/anisotropic.cpp), whose files still read and whose tests build them here.
std::unique_ptr<Representation> bake_anisotropic(const AnisotropicBakeSpec& spec, TermBackend& backend,
                                                 const std::function<void(std::size_t, std::size_t)>& progress = {},
                                                 const std::string& preset_name = "",
                                                 std::optional<LookupDomain> domain = std::nullopt);

// The surfaces bake_anisotropic fits for a slab of projected alphas (alpha_v, alpha_l) = node^2: the
// relative azimuth dphi and slope correlation rho, the surface's alphas along its principal axes and
// the angle of its first axis from V's azimuth (its query: V at azimuth -axis_angle, L at
// dphi - axis_angle in the surface's frame).
struct AnisotropicSurface {
    double dphi, rho, alpha_x, alpha_y, axis_angle;
};
std::vector<AnisotropicSurface> anisotropic_surfaces(const AnisotropicBakeSpec& spec, double alpha_v, double alpha_l);

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
