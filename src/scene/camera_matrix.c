/* A camera from an engine's view and projection matrices (pgi_camera_from_matrices). */
#include <stdio.h>
#include <string.h>

#include "scene_internal.h"

/* Element (row, col) of a column-major 4x4 matrix. */
#define M(m, row, col) ((double)(m)[4 * (col) + (row)])

pgi_status pgi_camera_from_matrices(const float view[16], const float proj[16], int width, int height,
                                    pgi_camera_def *out, float shift[2]) {
    const char *what = "pgi_camera_from_matrices";
    if (!view || !proj || !out) return pgi__fail(PGI_ERR_INVALID_ARG, "%s: NULL argument", what);
    if (width < 1 || height < 1)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: image size %dx%d is not positive", what, width, height);
    for (int k = 0; k < 16; k++)
        if (!isfinite(view[k]) || !isfinite(proj[k]))
            return pgi__fail(PGI_ERR_INVALID_ARG, "%s: the %s matrix has a non-finite element (%d)", what,
                             isfinite(view[k]) ? "projection" : "view", k);
    /* The view matrix: [R t; 0 0 0 1] with R a rotation (rows: right, up, back). */
    if (M(view, 3, 0) != 0.0 || M(view, 3, 1) != 0.0 || M(view, 3, 2) != 0.0 || M(view, 3, 3) != 1.0)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: the view matrix's last row is not 0, 0, 0, 1 (not affine)", what);
    double R[3][3];
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) R[r][c] = M(view, r, c);
    const double det = R[0][0] * (R[1][1] * R[2][2] - R[1][2] * R[2][1]) -
                       R[0][1] * (R[1][0] * R[2][2] - R[1][2] * R[2][0]) +
                       R[0][2] * (R[1][0] * R[2][1] - R[1][1] * R[2][0]);
    if (!(fabs(det) > 1e-12))
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: the view matrix is singular (determinant %g)", what, det);
    for (int a = 0; a < 3; a++)
        for (int b = a; b < 3; b++) {
            const double dot = R[a][0] * R[b][0] + R[a][1] * R[b][1] + R[a][2] * R[b][2];
            if (fabs(dot - (a == b ? 1.0 : 0.0)) > 1e-3)
                return pgi__fail(PGI_ERR_INVALID_ARG,
                                 "%s: the view matrix is not a rotation and a translation (rows %d and %d of its 3x3 "
                                 "part have a dot product of %g: scaled or sheared)",
                                 what, a, b, dot);
        }
    if (det < 0.0)
        return pgi__fail(PGI_ERR_INVALID_ARG,
                         "%s: the view matrix mirrors (determinant %g; a right-handed camera "
                         "looks down -z with y up)",
                         what, det);
    /* The projection: perspective (last row 0, 0, -1, 0), no skew. */
    if (M(proj, 3, 0) != 0.0 || M(proj, 3, 1) != 0.0 || M(proj, 3, 2) != -1.0 || M(proj, 3, 3) != 0.0)
        return pgi__fail(PGI_ERR_INVALID_ARG,
                         "%s: the projection is not a perspective one (last row %g, %g, %g, %g, not 0, 0, -1, 0%s)",
                         what, M(proj, 3, 0), M(proj, 3, 1), M(proj, 3, 2), M(proj, 3, 3),
                         M(proj, 3, 3) == 1.0 ? ": orthographic" : "");
    if (M(proj, 0, 1) != 0.0 || M(proj, 1, 0) != 0.0)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: the projection is skewed (P[0][1] = %g, P[1][0] = %g)", what,
                         M(proj, 0, 1), M(proj, 1, 0));
    const double p00 = M(proj, 0, 0), p11 = M(proj, 1, 1);
    if (!(p00 > 0.0 && p11 > 0.0))
        return pgi__fail(PGI_ERR_INVALID_ARG,
                         "%s: the projection's P[0][0] = %g and P[1][1] = %g must be positive (singular or flipped)",
                         what, p00, p11);
    const double aspect = p11 / p00, image = (double)width / (double)height;
    if (fabs(aspect / image - 1.0) > 1e-3)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: the projection's aspect %g is not the image's %dx%d (%g)", what,
                         aspect, width, height, image);
    const double fov = 2.0 * atan(1.0 / p11) * (180.0 / 3.14159265358979323846);
    if (!(fov > 0.0 && fov < 180.0))
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: the projection's field of view %g is outside (0, 180) degrees", what,
                         fov);
    const double sx = M(proj, 0, 2) * (double)width / 2.0, sy = -M(proj, 1, 2) * (double)height / 2.0;
    if (!(fabs(sx) <= 0.5 + 1e-6 && fabs(sy) <= 0.5 + 1e-6))
        return pgi__fail(PGI_ERR_INVALID_ARG,
                         "%s: the projection is off-centre by (%g, %g) pixels; at most half a pixel (a sub-pixel "
                         "jitter) is supported",
                         what, sx, sy);

    memset(out, 0, sizeof *out);
    double eye[3];
    for (int c = 0; c < 3; c++) /* -R^T t */
        eye[c] = -(R[0][c] * M(view, 0, 3) + R[1][c] * M(view, 1, 3) + R[2][c] * M(view, 2, 3));
    for (int c = 0; c < 3; c++) {
        out->eye[c] = (float)eye[c];
        out->look_at[c] = (float)(eye[c] - R[2][c]); /* forward: -z */
        out->up[c] = (float)R[1][c];
    }
    /* The float field of view whose tangent, as the renderer computes it, is nearest 1 / P[1][1]. */
    const double want = 1.0 / p11;
    float best = (float)fov;
    double err = INFINITY;
    float f = nextafterf((float)fov, 0.f);
    for (int k = 0; k < 3; k++, f = nextafterf(f, 180.f)) {
        const double e = fabs((double)tanf(0.5f * f * PGI__PI / 180.f) - want);
        if (e < err) err = e, best = f;
    }
    out->fov_y_deg = best;
    if (shift) {
        shift[0] = (float)fmax(-0.5, fmin(0.5, sx));
        shift[1] = (float)fmax(-0.5, fmin(0.5, sy));
    } else if (sx != 0.0 || sy != 0.0)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: the projection is off-centre by (%g, %g) pixels and `shift` is NULL",
                         what, sx, sy);
    for (int c = 0; c < 3; c++)
        if (!(fabsf(out->eye[c]) <= PGI_MAX_COORD) || !(fabsf(out->look_at[c]) <= PGI_MAX_COORD))
            return pgi__fail(PGI_ERR_INVALID_ARG, "%s: the eye (%g, %g, %g) is beyond the coordinate range (-%g..%g)",
                             what, eye[0], eye[1], eye[2], (double)PGI_MAX_COORD, (double)PGI_MAX_COORD);
    return PGI_OK;
}
