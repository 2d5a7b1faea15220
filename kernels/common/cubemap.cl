/* Cubemap face coordinates, shared by every kernel that reads or writes a cube (prefilter, irradiance).
 * Faces +X -X +Y -Y +Z -Z (0..5), OpenGL's orientation: a face's (s, t) in [-1, 1] with s to the right
 * and t down, as the face images are stored (docs/ibl.md, "Face order and orientation"). The host's
 * own copy (host/env/cubemap.cpp) is the oracle's and stays separate code. */

/* The direction (normalised) through (s, t) of a face. */
inline float3 ms_cube_direction(int face, float s, float t)
{
    float3 d;
    switch (face) {
    case 0: d = (float3)(1.0f, -t, -s); break;
    case 1: d = (float3)(-1.0f, -t, s); break;
    case 2: d = (float3)(s, 1.0f, t); break;
    case 3: d = (float3)(s, -1.0f, -t); break;
    case 4: d = (float3)(s, -t, 1.0f); break;
    default: d = (float3)(-s, -t, -1.0f); break;
    }
    return normalize(d);
}

/* The face of a direction (its largest component) and (s, t) on it: the inverse of ms_cube_direction. */
inline int ms_cube_face_st(float3 d, float* s, float* t)
{
    const float ax = fabs(d.x), ay = fabs(d.y), az = fabs(d.z);
    if (ax >= ay && ax >= az) {
        *s = (d.x > 0.0f ? -d.z : d.z) / ax;
        *t = -d.y / ax;
        return d.x > 0.0f ? 0 : 1;
    }
    if (ay >= az) {
        *s = d.x / ay;
        *t = (d.y > 0.0f ? d.z : -d.z) / ay;
        return d.y > 0.0f ? 2 : 3;
    }
    *s = (d.z > 0.0f ? d.x : -d.x) / az;
    *t = -d.y / az;
    return d.z > 0.0f ? 4 : 5;
}
