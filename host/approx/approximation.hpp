// One interface for everything a renderer could ship in place of the term: part 1's formulas, part 2's
// baked LUTs and the representations that keep the relative azimuth (host/repr/). Each answers the
// renderer's question at (visibility, NdotL, NdotV, roughness, relative azimuth), says what it costs a
// renderer per light, where its answers hold (its domain) and how it was made. eval --compare, sweeps,
// scenes, bake --scene and design all judge approximations through this interface; jobs/compare.hpp
// opens them by name or file.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "core/lookup_domain.hpp"
#include "core/query.hpp"
#include "core/types.hpp"

namespace ms::approx {

// What every approximation reads. roughness is the perceptual roughness (alpha = roughness^2); for an
// anisotropic query the isotropic equivalent (see isotropic_roughness).
struct Inputs {
    double visibility = 1;
    double n_dot_l = 1;
    double n_dot_v = 1;
    double roughness = 0.5;
    AoWeighting weighting = AoWeighting::cosine;
    // The relative azimuth between the projections of V and L on the surface, in radians in [0, pi]
    // (0: L on V's side, pi: opposite). Part 2's LUTs and part 1's terms ignore it; representations
    // that keep the azimuth read it. 0 when either direction is along the normal.
    double relative_azimuth = 0;
    // The anisotropic surface in its tangent frame (x = tangent, y = bitangent): alpha_x, alpha_y and
    // the azimuths of V's and L's projections measured from the tangent, in radians. inputs_of fills
    // them from a query's directions; alpha_x = 0 (unset) means isotropic with alpha = roughness^2, V at
    // azimuth 0 and L at relative_azimuth. Only representations of the anisotropic term read them.
    double alpha_x = 0, alpha_y = 0;
    double view_azimuth = 0, light_azimuth = 0;
};

// What an approximation costs a renderer per light: texture memory, filtered fetches and an ALU
// estimate (arithmetic instructions of its shader after the fetches, counted from the generated code
// by lut/shader/alu_count.hpp).
struct Cost {
    std::uint64_t bytes = 0;
    unsigned fetches_per_light = 0;
    unsigned alu_per_light = 0;
    std::string storage;  // e.g. "3D texture 32x32x32 RGBA16F"
};

class Approximation {
public:
    virtual ~Approximation() = default;
    // "analytic", "lut", or a representation's own kind ("azimuth-harmonics", ...).
    virtual std::string kind() const = 0;
    // What it is, in words (a term's name, a LUT's layout, a representation's kind and layout).
    virtual std::string name() const = 0;
    virtual Cost cost() const = 0;
    // The renderer's answer at `in`. May throw std::domain_error where the approximation refuses to
    // answer (a roughness outside a formula's range, an unbaked texel, a "refused" domain).
    virtual double operator()(const Inputs& in) const = 0;
    // Where its answers hold as measured (a file's "domain"); none: everywhere (part 1's formulas).
    virtual std::optional<LookupDomain> domain() const { return std::nullopt; }
    // How it was made: {kind, ...} (a file's version and command line, a term's name).
    virtual nlohmann::json provenance() const = 0;
};

// The isotropic-equivalent roughness of (alpha_x, alpha_y): (alpha_x alpha_y)^(1/4), the square root
// of the geometric-mean alpha (it keeps the area of the slope distribution's footprint).
double isotropic_roughness(double alpha_x, double alpha_y);

// The inputs of a query: NdotV = wi_z and NdotL = wo_z of the normalised directions, roughness =
// isotropic_roughness(alpha_x, alpha_y), relative_azimuth = the angle between the tangent-plane
// projections of wi and wo; alpha_x, alpha_y and the tangent-relative azimuths of wi and wo.
Inputs inputs_of(const Query& q, AoWeighting weighting);

}  // namespace ms::approx
