// KTX 2.0 (Khronos Texture 2.0) LUT files: a 3D texture (width = visibility, height = NdotL, depth =
// NdotV) when the LUT has more than one NdotV slice, a 2D texture otherwise; RGBA = the roughness
// channels (padded, encoding.hpp), one mip level, no supercompression.
//
// Layout written (KTX 2.0 specification, section 3, "File Structure"), all little-endian:
//   identifier[12] = AB 4B 54 58 20 32 30 BB 0D 0A 1A 0A  ("«KTX 20»\r\n\x1A\n")
//   vkFormat, typeSize, pixelWidth, pixelHeight, pixelDepth (0 for 2D), layerCount = 0, faceCount = 1,
//   levelCount = 1, supercompressionScheme = 0                                    (9 x UInt32)
//   dfdByteOffset, dfdByteLength, kvdByteOffset, kvdByteLength (UInt32), sgdByteOffset = 0,
//   sgdByteLength = 0 (UInt64)                                                     -> 80 bytes
//   level index: byteOffset, byteLength, uncompressedByteLength (UInt64) for the one level
//   DFD: dfdTotalSize, then one basic descriptor block (Khronos Data Format Specification 1.3,
//        "Khronos Basic Data Format Descriptor Block"): vendorId 0 / descriptorType 0, versionNumber 2
//        (KHR_DF_VERSIONNUMBER_1_3), descriptorBlockSize = 24 + 16 x samples, colorModel 1 (RGBSDA),
//        colorPrimaries 1 (BT709), transferFunction 1 (LINEAR: the data are not sRGB-encoded),
//        flags 0 (ALPHA_STRAIGHT: the 4th channel is data, never premultiplied), texelBlockDimension
//        0,0,0,0 (1x1x1x1), bytesPlane0 = bytes per texel; 4 samples R, G, B, A (channel ids 0, 1, 2,
//        15) with bitOffset, bitLength - 1, qualifiers FLOAT|SIGNED (0xC0) for float formats and none
//        for UNORM, sampleLower/Upper -1.0f/1.0f bit patterns for floats, 0/(2^n - 1) for UNORM.
//   KVD: entries sorted by key (bytewise), each UInt32 keyAndValueByteLength, key NUL value, padded
//        to 4 bytes: "KTXorientation" = "rd" (2D) / "rdi" (3D) (x right, NdotL rows down, NdotV in),
//        "KTXwriter" = "microshadow <version>", "microshadow" = the metadata JSON (NUL-terminated).
//   level data at a multiple of lcm(bytes per texel, 4): texels x fastest, then y, then z.
#pragma once

#include <cstdint>
#include <string>

#include "lut/exr_lut.hpp"
#include "lut/formats/encoding.hpp"
#include "lut/formats/texture.hpp"

namespace ms::lutfmt {

// VkFormat enum values (Vulkan 1.0 core).
constexpr std::uint32_t kVkR8G8B8A8Unorm = 37, kVkR16G16B16A16Unorm = 91, kVkR16G16B16A16Sfloat = 97,
                        kVkR32G32B32A32Sfloat = 109;
constexpr std::uint32_t kVkR8G8Unorm = 16, kVkR16G16Unorm = 77, kVkR16G16Sfloat = 83, kVkR32G32Sfloat = 103;
std::uint32_t vk_format(PixelEncoding);
std::uint32_t vk_format_rg(PixelEncoding);  // the two-component (RG) format of the encoding

// The LUT as the TextureData texture_writer.hpp writes as KTX2. std::invalid_argument for a bad LUT.
TextureData ktx2_lut_texture(const LutFile& lut, PixelEncoding encoding);

}  // namespace ms::lutfmt
