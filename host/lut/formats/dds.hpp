// DirectDraw Surface LUT files with the DX10 header extension: a volume texture (width = visibility,
// height = NdotL, depth = NdotV) when the LUT has more than one NdotV slice, a 2D texture otherwise.
//
// Layout (Microsoft "DDS_HEADER", "DDS_PIXELFORMAT", "DDS_HEADER_DXT10" reference pages), little-endian:
//   magic "DDS " (0x20534444)
//   DDS_HEADER (124 bytes): dwSize 124, dwFlags CAPS|HEIGHT|WIDTH|PITCH|PIXELFORMAT (|DEPTH for a
//     volume), dwHeight, dwWidth, dwPitchOrLinearSize = width x bytes per texel, dwDepth, dwMipMapCount 1,
//     dwReserved1[11], ddspf { dwSize 32, dwFlags DDPF_FOURCC, dwFourCC "DX10", 0 x 5 },
//     dwCaps DDSCAPS_TEXTURE (|COMPLEX for a volume), dwCaps2 DDSCAPS2_VOLUME for a volume, dwCaps3, dwCaps4, dwReserved2 = 0
//   DDS_HEADER_DXT10 (20 bytes): dxgiFormat (R32G32B32A32_FLOAT 2, R16G16B16A16_FLOAT 10,
//     R16G16B16A16_UNORM 11, R8G8B8A8_UNORM 28), resourceDimension (TEXTURE2D 3, TEXTURE3D 4),
//     miscFlag 0, arraySize 1, miscFlags2 = DDS_ALPHA_MODE_CUSTOM (4: the 4th channel is data, not alpha)
//   texels: x fastest, then y, then z; RGBA = roughness channels (padded, encoding.hpp).
// DDS has no place for metadata: the metadata JSON (with the error budget) goes beside the file as
// `<file>.json`, written first, so a .dds that exists always has its record.
#pragma once

#include <cstdint>
#include <string>

#include "lut/exr_lut.hpp"
#include "lut/formats/encoding.hpp"
#include "lut/formats/texture.hpp"

namespace ms::lutfmt {

constexpr std::uint32_t kDxgiR32G32B32A32Float = 2, kDxgiR16G16B16A16Float = 10, kDxgiR16G16B16A16Unorm = 11,
                        kDxgiR8G8B8A8Unorm = 28;
constexpr std::uint32_t kDxgiR32G32Float = 16, kDxgiR16G16Float = 34, kDxgiR16G16Unorm = 35, kDxgiR8G8Unorm = 49;
std::uint32_t dxgi_format(PixelEncoding);
std::uint32_t dxgi_format_rg(PixelEncoding);  // the two-component (RG) format of the encoding

// The LUT as the TextureData texture_writer.hpp writes as DDS. std::invalid_argument for a bad LUT.
TextureData dds_lut_texture(const LutFile& lut, PixelEncoding encoding);

}  // namespace ms::lutfmt
