/* microshadow LUT (custom), written by microshadow 0.1.0. Generated: do not edit.
 * 3D texture: width 2 (visibility), height 2 (NdotL, increasing downwards), depth 2 (NdotV); 4 components per texel, float32.
 * index = ((z * height + y) * width + x) * 4 + c; sample with linear filtering, clamp-to-edge, no mips.
 * axis visibility: [0, 1], 2 texels, texel centres: p_i = min + (max - min) (i + 0.5) / n
 * axis n_dot_l: [0, 1], 2 texels, texel centres: p_i = min + (max - min) (i + 0.5) / n
 * axis n_dot_v: [0, 1], 2 texels, texel centres: p_i = min + (max - min) (i + 0.5) / n
 * channel R: roughness 0.3 (alpha 0.09)
 * channel G: roughness 0.8 (alpha 0.64)
 * channel B: padding, repeats channel G
 * channel A: padding, repeats channel G
 * error budget: sampling 0.0100899 + azimuth quadrature 0.0304129 + quantisation 0 = 0.0405028
 */
#ifndef TINY_H
#define TINY_H

#include <stdint.h>

#define TINY_WIDTH 2u  /* visibility texels */
#define TINY_HEIGHT 2u  /* NdotL texels */
#define TINY_DEPTH 2u  /* NdotV texels (1: a 2D texture) */
#define TINY_COMPONENTS 4u
#define TINY_ROUGHNESS_CHANNELS 2u
#define TINY_VISIBILITY_MIN 0
#define TINY_VISIBILITY_MAX 1
#define TINY_VISIBILITY_TEXEL_CENTRES 1
#define TINY_N_DOT_L_MIN 0
#define TINY_N_DOT_L_MAX 1
#define TINY_N_DOT_L_TEXEL_CENTRES 1
#define TINY_N_DOT_V_MIN 0
#define TINY_N_DOT_V_MAX 1
#define TINY_N_DOT_V_TEXEL_CENTRES 1
#define TINY_ROUGHNESS_R 0.29999999999999999
#define TINY_ROUGHNESS_G 0.80000000000000004
#define TINY_MAX_TOTAL_ERROR 0.0405028
#define TINY_COSINE_AO 1  /* zero region: 2 v + NdotL <= 1 (cosine) or NdotL <= 2 (1 - v)^2 - 1 (uniform) */

static const char tiny_metadata[] =
    "{\"ao_weighting\":\"cosine\",\"axes\":[{\"count\":2,\"max\":1.0,\"min\":0.0,\"name\":\"visibility\",\"texel\":\"centres\"},{\"count\":2,\"max\":"
    "1.0,\"min\":0.0,\"name\":\"n_dot_l\",\"texel\":\"centres\"},{\"count\":2,\"max\":1.0,\"min\":0.0,\"name\":\"n_dot_v\",\"texel\":\"centres\"}],\"a"
    "zimuth\":\"mean\",\"azimuth_nodes\":3,\"azimuth_quadrature\":\"trapezoid on [0, 180] degrees\",\"azimuth_quadrature_error\":0.03041"
    "2946428571425,\"backend\":\"opencl\",\"batches\":4,\"channels\":[{\"alpha_x\":0.09,\"alpha_y\":0.09,\"name\":\"R\",\"roughness\":0.3,\"text"
    "ure_channel\":\"R\"},{\"alpha_x\":0.6400000000000001,\"alpha_y\":0.6400000000000001,\"name\":\"G\",\"roughness\":0.8,\"texture_channel"
    "\":\"G\"}],\"command_line\":\"/work/wt-lib/build/microshadow lut export s.exr --out tiny.h\",\"device\":\"pthread-skylake-avx512-I"
    "ntel(R) Xeon(R) Processor [Portable Computing Language]\",\"double_kernels\":false,\"encoding\":\"float32\",\"error_budget\":{\"az"
    "imuth_quadrature\":0.030412946428571425,\"azimuth_quadrature_kind\":\"azimuth_quadrature_error: max |T_K/2 - T_K| over rows\""
    ",\"quantisation\":0.0,\"quantisation_kind\":\"none: the baked float32 values are stored exactly\",\"sampling\":0.010089884705726"
    "793,\"sampling_kind\":\"max_error: largest per-texel replicate standard error\",\"total\":0.040502831134298214},\"exported_from"
    "\":{\"encoding\":\"float32\",\"file\":\"s.exr\",\"format\":\"exr\"},\"fast_math\":false,\"file_format\":\"c-header\",\"form\":\"height-correla"
    "ted\",\"layout\":\"custom\",\"max_error\":0.010089884705726793,\"max_error_kind\":\"largest per-texel standard error (replicate sp"
    "read)\",\"max_samples_per_slice\":256,\"max_total_error\":0.040502831134298214,\"n_dot_l_clamp_min\":0.0001,\"n_dot_v_clamp_min\""
    ":0.0001,\"padded_channels\":[\"B\",\"A\"],\"padding\":\"channels [\\\"B\\\",\\\"A\\\"] repeat channel G (the highest-index roughness chan"
    "nel); read only the first 2\",\"program\":\"microshadow 0.1.0\",\"replicates\":8,\"rerun_chunks\":0,\"samples\":256,\"seed\":0,\"seque"
    "nce\":\"sobol\",\"skipped_one\":0,\"skipped_zero\":4,\"texture_channels\":4,\"tolerance\":0.0,\"tolerance_met\":true,\"version\":\"0.1.0"
    "\"}";

static const float tiny_data[TINY_DEPTH * TINY_HEIGHT * TINY_WIDTH * 4u] = {
    0.0f, 0.0f, 0.0f, 0.0f,
    0.0338755138f, 0.237444192f, 0.237444192f, 0.237444192f,
    0.0234836377f, 0.0591744073f, 0.0591744073f, 0.0591744073f,
    0.970342577f, 0.518732548f, 0.518732548f, 0.518732548f,
    0.0f, 0.0f, 0.0f, 0.0f,
    0.0231006201f, 0.279995233f, 0.279995233f, 0.279995233f,
    0.0254519004f, 0.0964049697f, 0.0964049697f, 0.0964049697f,
    0.981380224f, 0.644103646f, 0.644103646f, 0.644103646f
};

#endif
