/*
 * sincos.cl - cos(2 pi u) and sin(2 pi u) for u in [0, 1), sixteen lanes at a time.
 *
 * PoCL 3.1 keeps the sin and cos builtins scalar; this polynomial with integer quadrant selection
 * vectorises. Write 2 pi u = q pi/2 + a with q = round(4u) and a in [-pi/4, pi/4]; Taylor polynomials
 * of degree 7 (sin) and 8 (cos) are accurate to 3e-7 there, below float's resolution of the sampled
 * directions (double mode adds terms up to degree 12, 1e-11). The quadrant rotation is done with selects.
 */
inline void sincos_turns16(real16 u, real16* sin_out, real16* cos_out)
{
    const real16 t = u * MS_R(4.0);
    const int16 q = convert_int16(t + MS_R(0.5)); /* t >= 0, so truncation rounds to nearest */
    const real16 a = (t - convert_real16(q)) * MS_R(1.57079632679489662);
    const real16 a2 = a * a;
#if MS_REAL_IS_DOUBLE
    const real16 sa = a * (1.0 + a2 * (-1.0 / 6 + a2 * (1.0 / 120 + a2 * (-1.0 / 5040 + a2 * (1.0 / 362880 + a2 * (-1.0 / 39916800))))));
    const real16 ca = 1.0 + a2 * (-0.5 + a2 * (1.0 / 24 + a2 * (-1.0 / 720 + a2 * (1.0 / 40320 + a2 * (-1.0 / 3628800 + a2 * (1.0 / 479001600))))));
#else
    const real16 sa = a * (1.0f + a2 * (-1.0f / 6.0f + a2 * (1.0f / 120.0f + a2 * (-1.0f / 5040.0f))));
    const real16 ca = 1.0f + a2 * (-0.5f + a2 * (1.0f / 24.0f + a2 * (-1.0f / 720.0f + a2 * (1.0f / 40320.0f))));
#endif
    const mask16 quadrant = convert_mask16(q & 3);
    /* quadrant 0: (cos, sin) = (ca, sa); 1: (-sa, ca); 2: (-ca, -sa); 3: (sa, -ca) */
    const mask16 odd = (quadrant & 1) != 0;
    const real16 c = select(ca, sa, odd);
    const real16 s = select(sa, ca, odd);
    *cos_out = select(c, -c, (quadrant == 1) | (quadrant == 2));
    *sin_out = select(s, -s, quadrant >= 2);
}
