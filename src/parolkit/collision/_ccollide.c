/* Compiled collision kernel of parolkit: the hot paths of parolkit.collision.
 *
 * The same algorithms, step for step, as the numpy reference _reference.py (read that file for
 * the maths and the packed scene's layout); _reference.py is what runs when this module is not
 * built or PAROLKIT_PURE_PYTHON=1.  tests/unit/test_collision_native.py checks both agree.
 * Everything is in metres and radians.  No robot constant is written here: the packed scene
 * carries the DH rows, the shapes and the pairs.
 *
 * Entry points (packed: the scene's read-only float64 array):
 *   check(packed, q) -> (d_self, k_self, d_arm_zone, k_arm_zone, d_attached, k_attached,
 *                        worst_gap, k_worst) or None when q is not 6 plain finite numbers
 *       (the caller then raises the precise error).  d: smallest clearance of the category
 *       (inf, -1: no pair); worst_gap: smallest clearance - margin.  Ties: lowest pair index.
 *   distances(packed, qs (N,6), d (N,P), pa (N,P,3), pb (N,P,3)) -> None
 *       every pair's clearance and closest points (world) at every configuration.
 *   path(packed, qs (N,6), swept) -> (status, index, s, pair, gap, evaluations)
 *       the first violation along the samples (and between them when swept): see
 *       _reference.path for the statuses and the conservative advancement.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <string.h>

#define MAGIC 7301.0
#define HEADER 30
#define BODY_W 8
#define STATIC_W 16
#define PAIR_W 12
#define PLANE 0
#define BOX 1
#define CYLINDER 2
#define CAP_CAP 0
#define CAP_STATIC 1
#define BISECT_TOL 1e-10
#define BISECT_MAX 60
#define EPS_LEN2 1e-24
#define MAX_BODIES 256

typedef struct {
    Py_ssize_t m, s, p;
    double tau;
    double max_evals;
    const double *dh;      /* 6 x 4: d, a, cos alpha, sin alpha */
    const double *bodies;  /* m x 8 */
    const double *statics; /* s x 16 */
    const double *pairs;   /* p x 12 */
} Scene;

/* A C-contiguous float64 buffer of `count` doubles (count < 0: any length). */
static int
get_f64(PyObject *obj, Py_buffer *view, int writable, Py_ssize_t count, const char *name)
{
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(obj, view, flags) < 0)
        return 0;
    const char *f = view->format ? view->format : "B";
    if (*f == '<' || *f == '=' || *f == '@')
        f++;
    if (view->itemsize != 8 || strcmp(f, "d") != 0 || (count >= 0 && view->len != count * 8)) {
        PyErr_Format(PyExc_TypeError, "%s must be a C-contiguous float64 array%s", name,
                     count < 0 ? "" : " of the right size");
        PyBuffer_Release(view);
        return 0;
    }
    return 1;
}

static int
scene_from(PyObject *obj, Py_buffer *view, Scene *sc)
{
    if (!get_f64(obj, view, 0, -1, "packed"))
        return 0;
    const double *b = (const double *)view->buf;
    Py_ssize_t n = view->len / 8;
    if (n < HEADER || b[0] != MAGIC) {
        PyErr_SetString(PyExc_ValueError, "not a packed collision scene");
        PyBuffer_Release(view);
        return 0;
    }
    sc->m = (Py_ssize_t)b[1];
    sc->s = (Py_ssize_t)b[2];
    sc->p = (Py_ssize_t)b[3];
    if (sc->m < 0 || sc->m > MAX_BODIES) {
        PyErr_Format(PyExc_ValueError, "packed collision scene: %zd bodies, at most %d", sc->m, MAX_BODIES);
        PyBuffer_Release(view);
        return 0;
    }
    if (sc->s < 0 || sc->p < 0 || n != HEADER + sc->m * BODY_W + sc->s * STATIC_W + sc->p * PAIR_W) {
        PyErr_SetString(PyExc_ValueError, "packed collision scene of the wrong length");
        PyBuffer_Release(view);
        return 0;
    }
    sc->tau = b[4];
    sc->max_evals = b[5];
    sc->dh = b + 6;
    sc->bodies = b + HEADER;
    sc->statics = sc->bodies + sc->m * BODY_W;
    sc->pairs = sc->statics + sc->s * STATIC_W;
    /* indices in range: the pair loop trusts them */
    for (Py_ssize_t k = 0; k < sc->m; k++) {
        double f = sc->bodies[k * BODY_W];
        if (!(f >= 0 && f <= 6)) {
            PyErr_SetString(PyExc_ValueError, "packed collision scene: body frame out of range");
            PyBuffer_Release(view);
            return 0;
        }
    }
    for (Py_ssize_t k = 0; k < sc->p; k++) {
        const double *pr = sc->pairs + k * PAIR_W;
        Py_ssize_t lim = pr[0] == CAP_CAP ? sc->m : sc->s;
        if (!(pr[1] >= 0 && pr[1] < sc->m && pr[2] >= 0 && pr[2] < lim && pr[3] >= 0 && pr[3] <= 2)) {
            PyErr_SetString(PyExc_ValueError, "packed collision scene: pair index out of range");
            PyBuffer_Release(view);
            return 0;
        }
    }
    return 1;
}

/* ---- kinematics: frames 0..6 (base, DH frames 1..5, flange), as _reference.frames ---- */

static void
frames(const double *dh, const double *q, double R[7][9], double P[7][3])
{
    static const double I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    memcpy(R[0], I, sizeof I);
    P[0][0] = P[0][1] = P[0][2] = 0.0;
    for (int k = 0; k < 6; k++) {
        double d = dh[4 * k], a = dh[4 * k + 1], ca = dh[4 * k + 2], sa = dh[4 * k + 3];
        double ct = cos(q[k]), st = sin(q[k]);
        const double *r = R[k];
        double *o = R[k + 1];
        for (int i = 0; i < 3; i++) {
            double r0 = r[3 * i], r1 = r[3 * i + 1], r2 = r[3 * i + 2];
            o[3 * i] = r0 * ct + r1 * st;
            o[3 * i + 1] = (r0 * (-st * ca) + r1 * (ct * ca)) + r2 * sa;
            o[3 * i + 2] = (r0 * (st * sa) + r1 * (-ct * sa)) + r2 * ca;
            P[k + 1][i] = P[k][i] + (r0 * (a * ct) + r1 * (a * st)) + r2 * d;
        }
    }
}

/* World end points of every body's axis segment. */
static void
segments(const Scene *sc, const double *q, double (*A)[3], double (*B)[3])
{
    double R[7][9], P[7][3];
    frames(sc->dh, q, R, P);
    for (Py_ssize_t k = 0; k < sc->m; k++) {
        const double *b = sc->bodies + k * BODY_W;
        int f = (int)b[0];
        const double *r = R[f];
        for (int i = 0; i < 3; i++) {
            A[k][i] = (r[3 * i] * b[1] + r[3 * i + 1] * b[2] + r[3 * i + 2] * b[3]) + P[f][i];
            B[k][i] = (r[3 * i] * b[4] + r[3 * i + 1] * b[5] + r[3 * i + 2] * b[6]) + P[f][i];
        }
    }
}

/* ---- distances ---- */

static inline double dot3(const double *x, const double *y) { return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]; }
static inline double clamp01(double v) { return v < 0.0 ? 0.0 : (v > 1.0 ? 1.0 : v); }

/* Closest points of [a0, a1] and [b0, b1]; returns their distance. */
static double
segseg(const double *a0, const double *a1, const double *b0, const double *b1, double *pa, double *pb)
{
    double d1[3], d2[3], r[3];
    for (int i = 0; i < 3; i++) {
        d1[i] = a1[i] - a0[i];
        d2[i] = b1[i] - b0[i];
        r[i] = a0[i] - b0[i];
    }
    double a = dot3(d1, d1), e = dot3(d2, d2), f = dot3(d2, r), c = dot3(d1, r), b = dot3(d1, d2);
    double s, t;
    if (a <= EPS_LEN2 && e <= EPS_LEN2) {
        s = 0.0;
        t = 0.0;
    } else if (a <= EPS_LEN2) {
        s = 0.0;
        t = clamp01(f / e);
    } else if (e <= EPS_LEN2) {
        t = 0.0;
        s = clamp01(-c / a);
    } else {
        double den = a * e - b * b;
        s = den > 1e-12 * a * e ? clamp01((b * f - c * e) / den) : 0.0;
        t = (b * s + f) / e;
        if (t < 0.0) {
            t = 0.0;
            s = clamp01(-c / a);
        } else if (t > 1.0) {
            t = 1.0;
            s = clamp01((b - c) / a);
        }
    }
    double v[3];
    for (int i = 0; i < 3; i++) {
        pa[i] = a0[i] + s * d1[i];
        pb[i] = b0[i] + t * d2[i];
        v[i] = pa[i] - pb[i];
    }
    return sqrt(dot3(v, v));
}

/* Closest point of the solid box / cylinder (local frame, half sizes e) to x. */
static inline void
project(int kind, const double *x, const double *e, double *y)
{
    if (kind == BOX) {
        for (int i = 0; i < 3; i++)
            y[i] = x[i] < -e[i] ? -e[i] : (x[i] > e[i] ? e[i] : x[i]);
        return;
    }
    double rho = hypot(x[0], x[1]);
    double k = rho > e[0] ? e[0] / rho : 1.0;
    y[0] = x[0] * k;
    y[1] = x[1] * k;
    y[2] = x[2] < -e[1] ? -e[1] : (x[2] > e[1] ? e[1] : x[2]);
}

static inline void
fg(int kind, const double *p0, const double *dv, const double *e, double t, double *f, double *g, double *y)
{
    double x[3], v[3];
    for (int i = 0; i < 3; i++)
        x[i] = p0[i] + t * dv[i];
    project(kind, x, e, y);
    for (int i = 0; i < 3; i++)
        v[i] = x[i] - y[i];
    *f = sqrt(dot3(v, v));
    *g = *f > 0.0 ? dot3(v, dv) / *f : 0.0;
}

/* Distance from [A, B] to a box or cylinder static: bisection on the derivative of the convex
 * f(t), as _reference._seg_convex.  pa: closest point of the segment, pb: of the shape (world). */
static double
seg_convex(const double *st, const double *A, const double *B, double *pa, double *pb)
{
    int kind = (int)st[0];
    const double *c = st + 1, *R = st + 4, *e = st + 13;
    double p0[3], p1[3], dv[3];
    for (int i = 0; i < 3; i++) {  /* x_local = R^T (x - c) */
        p0[i] = R[i] * (A[0] - c[0]) + R[3 + i] * (A[1] - c[1]) + R[6 + i] * (A[2] - c[2]);
        p1[i] = R[i] * (B[0] - c[0]) + R[3 + i] * (B[1] - c[1]) + R[6 + i] * (B[2] - c[2]);
    }
    for (int i = 0; i < 3; i++)
        dv[i] = p1[i] - p0[i];
    double f0, g0, y0[3], t, f, y[3];
    fg(kind, p0, dv, e, 0.0, &f0, &g0, y0);
    if (g0 >= 0.0) {
        t = 0.0;
        f = f0;
        memcpy(y, y0, sizeof y);
    } else {
        double f1, g1, y1[3];
        fg(kind, p0, dv, e, 1.0, &f1, &g1, y1);
        if (!(g1 > 0.0)) {
            t = 1.0;
            f = f1;
            memcpy(y, y1, sizeof y);
        } else {
            double lo = 0.0, hi = 1.0, flo = f0, glo = g0, fhi = f1, ghi = g1, ylo[3], yhi[3];
            memcpy(ylo, y0, sizeof ylo);
            memcpy(yhi, y1, sizeof yhi);
            for (int it = 0; it < BISECT_MAX; it++) {
                double tx = (fhi - flo + glo * lo - ghi * hi) / (glo - ghi);
                double lower = flo + glo * (tx - lo);
                if (lower < 0.0)
                    lower = 0.0;
                double upper = flo < fhi ? flo : fhi;
                if (upper - lower <= BISECT_TOL)
                    break;
                double mid = 0.5 * (lo + hi), fm, gm, ym[3];
                fg(kind, p0, dv, e, mid, &fm, &gm, ym);
                if (fm == 0.0 || gm == 0.0) {
                    lo = hi = mid;
                    flo = fhi = fm;
                    memcpy(ylo, ym, sizeof ylo);
                    memcpy(yhi, ym, sizeof yhi);
                    break;
                }
                if (gm > 0.0) {
                    hi = mid; fhi = fm; ghi = gm;
                    memcpy(yhi, ym, sizeof yhi);
                } else {
                    lo = mid; flo = fm; glo = gm;
                    memcpy(ylo, ym, sizeof ylo);
                }
            }
            if (flo <= fhi) {
                t = lo; f = flo;
                memcpy(y, ylo, sizeof y);
            } else {
                t = hi; f = fhi;
                memcpy(y, yhi, sizeof y);
            }
        }
    }
    for (int i = 0; i < 3; i++) {
        pa[i] = A[i] + t * (B[i] - A[i]);
        pb[i] = (R[3 * i] * y[0] + R[3 * i + 1] * y[1] + R[3 * i + 2] * y[2]) + c[i];
    }
    return f;
}

/* Exact clearance of pair k (world segments A, B of every body); closest points into pa, pb. */
static double
pair_clearance(const Scene *sc, Py_ssize_t k, double (*A)[3], double (*B)[3], double *pa, double *pb)
{
    const double *pr = sc->pairs + k * PAIR_W;
    Py_ssize_t i = (Py_ssize_t)pr[1], j = (Py_ssize_t)pr[2];
    double ri = sc->bodies[i * BODY_W + 7];
    if (pr[0] == CAP_CAP) {
        double d = segseg(A[i], B[i], A[j], B[j], pa, pb);
        return d - ri - sc->bodies[j * BODY_W + 7];
    }
    const double *st = sc->statics + j * STATIC_W;
    if (st[0] == PLANE) {
        const double *c = st + 1, *n = st + 13;
        double sa = (A[i][0] - c[0]) * n[0] + (A[i][1] - c[1]) * n[1] + (A[i][2] - c[2]) * n[2];
        double sb = (B[i][0] - c[0]) * n[0] + (B[i][1] - c[1]) * n[1] + (B[i][2] - c[2]) * n[2];
        int first = sa <= sb;
        double s = first ? sa : sb;
        const double *x = first ? A[i] : B[i];
        for (int t = 0; t < 3; t++) {
            pa[t] = x[t];
            pb[t] = x[t] - s * n[t];
        }
        return s - ri;
    }
    return seg_convex(st, A[i], B[i], pa, pb) - ri;
}

/* A lower bound of pair k's clearance that costs little (the exact value for cheap pairs:
 * *exact set to 1). */
static double
pair_lower_bound(const Scene *sc, Py_ssize_t k, double (*A)[3], double (*B)[3], int *exact)
{
    const double *pr = sc->pairs + k * PAIR_W;
    *exact = 0;
    if (pr[0] != CAP_STATIC) {
        *exact = 1;
        return 0.0;
    }
    const double *st = sc->statics + (Py_ssize_t)pr[2] * STATIC_W;
    if (st[0] == PLANE) {
        *exact = 1;
        return 0.0;
    }
    Py_ssize_t i = (Py_ssize_t)pr[1];
    double ri = sc->bodies[i * BODY_W + 7];
    const double *c = st + 1, *R = st + 4, *e = st + 13;
    if (st[0] == BOX) {  /* the box lies within its circumscribed sphere */
        double d[3], w[3];
        for (int t = 0; t < 3; t++) {
            d[t] = B[i][t] - A[i][t];
            w[t] = c[t] - A[i][t];
        }
        double dd = dot3(d, d);
        double s = dd > EPS_LEN2 ? clamp01(dot3(w, d) / dd) : 0.0;
        double v[3];
        for (int t = 0; t < 3; t++)
            v[t] = A[i][t] + s * d[t] - c[t];
        return sqrt(dot3(v, v)) - sqrt(dot3(e, e)) - ri;
    }
    /* the cylinder lies within the capsule of its radius around its axis */
    double a0[3], a1[3], pa[3], pb[3];
    for (int t = 0; t < 3; t++) {
        a0[t] = c[t] - e[1] * R[3 * t + 2];
        a1[t] = c[t] + e[1] * R[3 * t + 2];
    }
    return segseg(A[i], B[i], a0, a1, pa, pb) - e[0] - ri;
}

/* ---- joint vectors ---- */

/* 6 plain finite numbers from a list, tuple or float64 buffer; 0 (no error set) otherwise. */
static int
read_q(PyObject *obj, double *q)
{
    if (PyList_Check(obj) || PyTuple_Check(obj)) {
        if (PySequence_Fast_GET_SIZE(obj) != 6)
            return 0;
        PyObject **items = PySequence_Fast_ITEMS(obj);
        for (int i = 0; i < 6; i++) {
            PyObject *v = items[i];
            if (PyFloat_CheckExact(v))
                q[i] = PyFloat_AS_DOUBLE(v);
            else if (PyLong_CheckExact(v) || PyFloat_Check(v)) {
                q[i] = PyFloat_AsDouble(v);
                if (q[i] == -1.0 && PyErr_Occurred()) {
                    PyErr_Clear();
                    return 0;
                }
            } else
                return 0;
            if (!isfinite(q[i]))
                return 0;
        }
        return 1;
    }
    if (PyObject_CheckBuffer(obj)) {
        Py_buffer v;
        if (PyObject_GetBuffer(obj, &v, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0) {
            PyErr_Clear();
            return 0;
        }
        const char *f = v.format ? v.format : "B";
        if (*f == '<' || *f == '=' || *f == '@')
            f++;
        int ok = v.itemsize == 8 && strcmp(f, "d") == 0 && v.len == 48;
        if (ok) {
            memcpy(q, v.buf, 48);
            for (int i = 0; i < 6; i++)
                ok &= isfinite(q[i]) != 0;
        }
        PyBuffer_Release(&v);
        return ok;
    }
    return 0;
}

/* ---- check ---- */

static PyObject *
cc_check(PyObject *self, PyObject *args)
{
    PyObject *packed, *qo;
    if (!PyArg_UnpackTuple(args, "check", 2, 2, &packed, &qo))
        return NULL;
    double q[6];
    if (!read_q(qo, q))
        Py_RETURN_NONE;
    Py_buffer view;
    Scene sc;
    if (!scene_from(packed, &view, &sc))
        return NULL;
    double A[MAX_BODIES][3], B[MAX_BODIES][3], pa[3], pb[3];
    segments(&sc, q, A, B);
    double best[3] = {INFINITY, INFINITY, INFINITY}, worst = INFINITY;
    Py_ssize_t bi[3] = {-1, -1, -1}, wi = -1;
    for (Py_ssize_t k = 0; k < sc.p; k++) {
        const double *pr = sc.pairs + k * PAIR_W;
        int cat = (int)pr[3];
        double m = pr[4];
        int exact;
        double lb = pair_lower_bound(&sc, k, A, B, &exact);
        if (!exact && lb >= best[cat] && lb - m >= worst)
            continue;
        double d = pair_clearance(&sc, k, A, B, pa, pb);
        if (d < best[cat]) {
            best[cat] = d;
            bi[cat] = k;
        }
        if (d - m < worst) {
            worst = d - m;
            wi = k;
        }
    }
    PyBuffer_Release(&view);
    return Py_BuildValue("(dndndndn)", best[0], bi[0], best[1], bi[1], best[2], bi[2], worst, wi);
}

/* ---- distances ---- */

/* The packed scene and an (N, 6) float64 array of joint vectors ``qso``: both buffers held
   (the caller releases them) and *n set; 0 with an exception set and nothing held. */
static int
scene_and_qs(PyObject *packed, PyObject *qso, Py_buffer *view, Scene *sc, Py_buffer *vq, Py_ssize_t *n)
{
    if (!scene_from(packed, view, sc))
        return 0;
    if (!get_f64(qso, vq, 0, -1, "qs")) {
        PyBuffer_Release(view);
        return 0;
    }
    *n = vq->len / 48;
    if (vq->len != *n * 48) {
        PyErr_SetString(PyExc_TypeError, "qs must be an (N, 6) float64 array");
        PyBuffer_Release(vq);
        PyBuffer_Release(view);
        return 0;
    }
    return 1;
}

static PyObject *
cc_distances(PyObject *self, PyObject *args)
{
    PyObject *packed, *qso, *do_, *pao, *pbo;
    if (!PyArg_UnpackTuple(args, "distances", 5, 5, &packed, &qso, &do_, &pao, &pbo))
        return NULL;
    Py_buffer view, vq, vd, va, vb;
    Scene sc;
    Py_ssize_t n;
    if (!scene_and_qs(packed, qso, &view, &sc, &vq, &n))
        return NULL;
    if (!get_f64(do_, &vd, 1, n * sc.p, "d"))
        goto fail_q;
    if (!get_f64(pao, &va, 1, n * sc.p * 3, "pa"))
        goto fail_d;
    if (!get_f64(pbo, &vb, 1, n * sc.p * 3, "pb"))
        goto fail_a;
    const double *qs = (const double *)vq.buf;
    double *d = (double *)vd.buf, *pa = (double *)va.buf, *pb = (double *)vb.buf;
    double A[MAX_BODIES][3], B[MAX_BODIES][3];
    for (Py_ssize_t r = 0; r < n; r++) {
        segments(&sc, qs + 6 * r, A, B);
        for (Py_ssize_t k = 0; k < sc.p; k++) {
            Py_ssize_t o = r * sc.p + k;
            d[o] = pair_clearance(&sc, k, A, B, pa + 3 * o, pb + 3 * o);
        }
    }
    PyBuffer_Release(&vb);
    PyBuffer_Release(&va);
    PyBuffer_Release(&vd);
    PyBuffer_Release(&vq);
    PyBuffer_Release(&view);
    Py_RETURN_NONE;
fail_a:
    PyBuffer_Release(&va);
fail_d:
    PyBuffer_Release(&vd);
fail_q:
    PyBuffer_Release(&vq);
    PyBuffer_Release(&view);
    return NULL;
}

/* ---- path ---- */

/* The result of path(): status, index, s, pair, gap, evaluations. */
static PyObject *
path_result(int status, Py_ssize_t index, double s, Py_ssize_t pair, double gap, long evals)
{
    return Py_BuildValue("(indndl)", status, index, s, pair, gap, evals);
}

static PyObject *
cc_path(PyObject *self, PyObject *args)
{
    PyObject *packed, *qso;
    int swept;
    if (!PyArg_ParseTuple(args, "OOp", &packed, &qso, &swept))
        return NULL;
    Py_buffer view, vq;
    Scene sc;
    Py_ssize_t n;
    if (!scene_and_qs(packed, qso, &view, &sc, &vq, &n))
        return NULL;
    const double *qs = (const double *)vq.buf;
    Py_ssize_t np_ = sc.p;
    double A[MAX_BODIES][3], B[MAX_BODIES][3], pa[3], pb[3];
    PyObject *result = NULL;
    long evals = 0;
    if (n == 0 || np_ == 0) {
        result = path_result(0, -1, 0.0, -1, INFINITY, 0);
        goto done;
    }
    if (!swept) {
        for (Py_ssize_t k = 0; k < n; k++) {
            segments(&sc, qs + 6 * k, A, B);
            evals++;
            double worst = INFINITY;
            Py_ssize_t wi = -1;
            for (Py_ssize_t p = 0; p < np_; p++) {
                double m = sc.pairs[p * PAIR_W + 4];
                int exact;
                double lb = pair_lower_bound(&sc, p, A, B, &exact);
                if (!exact && lb - m > 0.0)  /* cannot violate: not the argmin of a violating sample */
                    continue;
                double g = pair_clearance(&sc, p, A, B, pa, pb) - m;
                if (g < worst) {
                    worst = g;
                    wi = p;
                }
            }
            if (wi >= 0 && worst <= 0.0) {
                result = path_result(1, k, 0.0, wi, worst, evals);
                goto done;
            }
        }
        result = path_result(0, -1, 0.0, -1, INFINITY, evals);
        goto done;
    }
    /* swept: conservative advancement, as _reference.path */
    double *budget = PyMem_Malloc(sizeof(double) * 3 * np_);
    Py_ssize_t *needy = PyMem_Malloc(sizeof(Py_ssize_t) * 2 * np_);
    unsigned char *left = PyMem_Malloc(np_ ? np_ : 1);
    if (!budget || !needy || !left) {
        PyMem_Free(budget);
        PyMem_Free(needy);
        PyMem_Free(left);
        PyErr_NoMemory();
        goto done;
    }
    double *rate = budget + np_, *horizon = budget + 2 * np_;
    Py_ssize_t *due = needy + np_;
    for (Py_ssize_t p = 0; p < np_; p++)
        budget[p] = 0.0;
    double tau = sc.tau;
    for (Py_ssize_t k = 0; k < n; k++) {
        const double *qk = qs + 6 * k;
        /* pairs not proven at this sample: evaluate them here */
        int any = 0;
        double worst = INFINITY;
        Py_ssize_t wi = -1;
        for (Py_ssize_t p = 0; p < np_; p++) {
            if (budget[p] > 0.0)
                continue;
            if (!any) {
                segments(&sc, qk, A, B);
                evals++;
                any = 1;
            }
            double g = pair_clearance(&sc, p, A, B, pa, pb) - sc.pairs[p * PAIR_W + 4];
            budget[p] = g;
            if (g < worst) {
                worst = g;
                wi = p;
            }
        }
        if (any && worst <= 0.0) {
            result = path_result(1, k, 0.0, wi, worst, evals);
            goto free_swept;
        }
        if (k == n - 1)
            break;
        const double *qn = qk + 6;
        double dq[6];
        for (int j = 0; j < 6; j++)
            dq[j] = fabs(qn[j] - qk[j]);
        Py_ssize_t nn = 0;
        for (Py_ssize_t p = 0; p < np_; p++) {
            const double *c = sc.pairs + p * PAIR_W + 5;
            double r = 0.0;
            for (int j = 0; j < 6; j++)
                r += c[j] * dq[j];
            rate[p] = r;
            if (budget[p] > r)
                budget[p] -= r;
            else {
                needy[nn] = p;
                horizon[nn] = budget[p] / r;
                left[nn] = 1;
                nn++;
            }
        }
        if (nn == 0)
            continue;
        for (;;) {
            double s = INFINITY;
            Py_ssize_t first = -1;
            for (Py_ssize_t t = 0; t < nn; t++)
                if (left[t] && horizon[t] < s) {
                    s = horizon[t];
                    first = t;
                }
            if (!(s < 1.0))
                break;
            if ((double)evals >= sc.max_evals) {
                result = path_result(3, k, s, needy[first], 0.0, evals);
                goto free_swept;
            }
            Py_ssize_t nd = 0;
            for (Py_ssize_t t = 0; t < nn; t++)
                if (left[t] && horizon[t] <= s)
                    due[nd++] = t;
            double q[6];
            for (int j = 0; j < 6; j++)
                q[j] = qk[j] + s * (qn[j] - qk[j]);
            segments(&sc, q, A, B);
            evals++;
            double gbad = INFINITY;
            Py_ssize_t wbad = -1;
            for (Py_ssize_t u = 0; u < nd; u++) {
                Py_ssize_t t = due[u], p = needy[t];
                double g = pair_clearance(&sc, p, A, B, pa, pb) - sc.pairs[p * PAIR_W + 4];
                if (g <= tau) {
                    if (g < gbad) {
                        gbad = g;
                        wbad = p;
                    }
                    continue;
                }
                horizon[t] = s + g / rate[p];
                if (horizon[t] >= 1.0) {
                    budget[p] = g - rate[p] * (1.0 - s);
                    left[t] = 0;
                }
            }
            if (wbad >= 0) {
                result = path_result(2, k, s, wbad, gbad, evals);
                goto free_swept;
            }
        }
        for (Py_ssize_t t = 0; t < nn; t++)
            if (left[t])
                budget[needy[t]] -= rate[needy[t]];
    }
    result = path_result(0, -1, 0.0, -1, INFINITY, evals);
free_swept:
    PyMem_Free(budget);
    PyMem_Free(needy);
    PyMem_Free(left);
done:
    PyBuffer_Release(&vq);
    PyBuffer_Release(&view);
    return result;
}

static PyMethodDef methods[] = {
    {"check", cc_check, METH_VARARGS, "check(packed, q) -> 8-tuple or None"},
    {"distances", cc_distances, METH_VARARGS, "distances(packed, qs, d, pa, pb) -> None"},
    {"path", cc_path, METH_VARARGS, "path(packed, qs, swept) -> (status, index, s, pair, gap, evaluations)"},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_ccollide",
    "Compiled collision kernel of parolkit (see parolkit/collision/_reference.py).", -1, methods,
};

PyMODINIT_FUNC
PyInit__ccollide(void)
{
    return PyModule_Create(&module);
}
