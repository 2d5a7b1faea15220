/*
 * real.cl - the working precision of every kernel (first file of the common preamble, after the
 * shared layout header). MS_REAL_IS_DOUBLE=1 (BuildConfig::double_precision, devices with cl_khr_fp64)
 * runs the same algorithms in double, which tells float rounding apart from algorithmic differences
 * when a kernel is compared with the oracle. Point sets stay float: their 24-bit values are exact in both.
 */
#if MS_REAL_IS_DOUBLE
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef double real;
typedef double3 real3;
typedef double4 real4;
typedef double16 real16;
typedef long16 mask16; /* vector comparisons of double16 yield long16 */
#define convert_real16 convert_double16
#define convert_mask16 convert_long16
#define MS_R(x) x
#else
typedef float real;
typedef float3 real3;
typedef float4 real4;
typedef float16 real16;
typedef int16 mask16;
#define convert_real16 convert_float16
#define convert_mask16 convert_int16
#define MS_R(x) x##f
#endif
