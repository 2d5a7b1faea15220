// Cubemaps of RGB radiance: conversion from equirectangular images and crosses, box-filtered mip chains,
// seamless bilinear and trilinear fetches (texels beyond a face's edge are read from the neighbouring
// face through their directions, so filtering never sees a seam), and cross unfoldings for files and
// previews. Face order and orientation: env/sphere.hpp (OpenGL / KTX2 / DDS).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "env/image.hpp"
#include "env/sphere.hpp"

namespace ms::env {

struct Cubemap {
    std::uint32_t size = 0;
    std::array<Image, 6> faces;  // RGB, size x size each

    explicit Cubemap(std::uint32_t n = 0);
    float* texel(int face, std::uint32_t x, std::uint32_t y) { return &faces[face].data[(std::size_t(y) * size + x) * 3]; }
    const float* texel(int face, std::uint32_t x, std::uint32_t y) const {
        return &faces[face].data[(std::size_t(y) * size + x) * 3];
    }
};

// Each face texel is the mean of ss x ss bilinear reads of the equirectangular image (wrapping in
// longitude, clamped at the poles).
Cubemap cubemap_from_equirect(const Image& equirect, std::uint32_t size, std::uint32_t supersample = 2);
// A horizontal (4n x 3n) or vertical (3n x 4n) cross; the vertical cross holds -Z below -Y, rotated by 180 degrees.
Cubemap cubemap_from_cross(const Image& cross);
// An environment image of any supported layout by its aspect ratio: 2:1 equirectangular (resampled to
// `size`, or to height / 2 rounded to a power of two when size = 0), 4:3 or 3:4 cross (kept as it is).
Cubemap cubemap_from_image(const Image& image, std::uint32_t size = 0);
// Six face images, one file each, in the order +X, -X, +Y, -Y, +Z, -Z (OpenGL / KTX2 / DDS; cmgen and
// glTF-IBL-Sampler name them px nx py ny pz nz), each oriented as env/sphere.hpp says: looking at the face
// from the cube's centre, +Y up on the side faces, row 0 at the top; +Y's top row borders -Z, -Y's top row
// borders +Z. These are the faces a horizontal cross holds, cut out unrotated. Validation: exactly six,
// each square, all the same size; `names` (the file names) go into the error messages.
Cubemap cubemap_from_faces(const std::vector<Image>& faces, const std::vector<std::string>& names);
// Reads the six files (OpenEXR or Radiance .hdr, read_environment_image) and calls cubemap_from_faces.
Cubemap read_cubemap_faces(const std::vector<std::string>& paths);

// Box-filtered chain: level k has size >> k, down to 1 (sizes must be powers of two).
std::vector<Cubemap> mip_chain(const Cubemap& base);

// Seamless bilinear read at direction d (unit).
std::array<float, 3> sample_bilinear(const Cubemap& cube, const Dir& d);
// Trilinear between the levels around lod (clamped to the chain).
std::array<float, 3> sample_trilinear(const std::vector<Cubemap>& chain, const Dir& d, double lod);

// Horizontal cross 4n x 3n: +Y above +Z; -X +Z +X -Z; -Y below +Z (unused area 0).
Image cross_image(const Cubemap& cube);
void cross_face_offset(int face, std::uint32_t n, std::uint32_t& x, std::uint32_t& y);

}  // namespace ms::env
