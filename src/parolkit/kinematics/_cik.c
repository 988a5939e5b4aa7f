/* Compiled single-pose IK of the PAROL6: the hot path of parolkit.kinematics.ik().
 *
 * This is the same algorithm, step for step and in the same floating-point order, as
 * solve_all_rad(..., best_only=True) and the pose conversion of _target_flange() in ik.py
 * (read that file for the maths).  ik.py stays the reference: it is what runs when this
 * module is not built (no C compiler) or PAROLKIT_PURE_PYTHON=1, and it explains failures
 * (this module only says "no solution"; ik.py's diagnose() says why).
 * tests/unit/test_kinematics_native.py checks both agree on every branch and edge case.
 *
 * No robot constant is written here: ik.py passes them all (derived from parolkit.robot,
 * the one source of truth) to configure() once at import.
 *
 * Entry points:
 *   configure(consts: 41 floats)  -- in the order of ik.py's _native_constants()
 *   ik(pose, seed, tool, shoulder, elbow, flip, out) -> int
 *       pose: list/tuple of 6 numbers (x, y, z mm, A, B, C deg)
 *       seed: list/tuple of 6 numbers (deg) or None (standby)
 *       tool: tuple (identity_rot, r00..r22, tx, ty, tz): the tool's flange->TCP transform
 *       shoulder / elbow / flip: -1 = any, else 0/1 (front/back, up/down, noflip/flip)
 *       out: writable buffer of 6 float64, receives the joint angles in degrees
 *       returns 1 = solved, 0 = no in-limit solution, -1 = input this fast path does not
 *       take (not plain finite ints/floats): the caller uses the Python path, which gives
 *       the precise error message.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <float.h>

#define N_CONST 41

static const double PI_ = 3.14159265358979311599796346854;       /* == math.pi */
static const double TWO_PI_ = 6.28318530717958623199592693709;   /* == 2 * math.pi */
static const double HALF_PI_ = 1.57079632679489655799898173427;  /* == math.pi / 2 */

static struct {
    double A1, A2, A3, D1, D4, K0, INV_2A2L, PHI3, PHI3_IN_RANGE, INV_2PI;
    double lo[6], hi[6], lom[6], hip[6], lom2pi[6], w[6];
    double hi6_low_twin, wrist_eps, shoulder_eps, reach_eps, deg, rad;
    double standby[6];
    int ready;
} K;

static PyObject *
cik_configure(PyObject *self, PyObject *arg)
{
    double v[N_CONST];
    PyObject *seq = PySequence_Fast(arg, "configure() takes a sequence of floats");
    if (seq == NULL)
        return NULL;
    if (PySequence_Fast_GET_SIZE(seq) != N_CONST) {
        PyErr_Format(PyExc_ValueError, "configure() takes %d constants, got %zd", N_CONST,
                     PySequence_Fast_GET_SIZE(seq));
        Py_DECREF(seq);
        return NULL;
    }
    for (int i = 0; i < N_CONST; i++) {
        v[i] = PyFloat_AsDouble(PySequence_Fast_GET_ITEM(seq, i));
        if (v[i] == -1.0 && PyErr_Occurred()) {
            Py_DECREF(seq);
            return NULL;
        }
    }
    Py_DECREF(seq);
    int k = 0;
    K.A1 = v[k++]; K.A2 = v[k++]; K.A3 = v[k++]; K.D1 = v[k++]; K.D4 = v[k++];
    K.K0 = v[k++]; K.INV_2A2L = v[k++]; K.PHI3 = v[k++]; K.PHI3_IN_RANGE = v[k++]; K.INV_2PI = v[k++];
    K.hi6_low_twin = v[k++]; K.wrist_eps = v[k++]; K.shoulder_eps = v[k++];
    K.reach_eps = v[k++]; K.deg = v[k++]; K.rad = v[k++];
    for (int j = 0; j < 6; j++) K.lo[j] = v[k++];
    for (int j = 0; j < 6; j++) K.hi[j] = v[k++];
    for (int j = 0; j < 6; j++) K.standby[j] = v[k++];
    /* the rest are derived exactly as ik.py derives them: lo - tol, hi + tol, weights */
    double tol = v[k++];
    for (int j = 0; j < 6; j++) K.w[j] = v[k++];
    if (k != N_CONST)
        Py_FatalError("parolkit _cik: constant table out of step");
    for (int j = 0; j < 6; j++) {
        K.lom[j] = K.lo[j] - tol;
        K.hip[j] = K.hi[j] + tol;
        K.lom2pi[j] = K.lom[j] + TWO_PI_;
    }
    K.ready = 1;
    Py_RETURN_NONE;
}

/* Map q into joint j's range [lo, hi] (ranges narrower than a turn: unique representation).
 * Returns 0 if it is out of range (beyond the tolerance). */
static inline int
fit(double *q, int j)
{
    double v = *q;
    if (v < K.lom[j] || v >= K.lom2pi[j])
        v -= TWO_PI_ * floor((v - K.lom[j]) * K.INV_2PI);
    if (v > K.hip[j])
        return 0;
    if (v < K.lo[j])
        v = K.lo[j];
    else if (v > K.hi[j])
        v = K.hi[j];
    *q = v;
    return 1;
}

/* J6 spans a full turn: where both q and q + 2 pi fit, the one nearer the seed. */
static inline double
fit6(double v, double s6)
{
    if (v < K.lom[5] || v >= K.lom2pi[5])
        v -= TWO_PI_ * floor((v - K.lom[5]) * K.INV_2PI);
    if (v <= K.hi6_low_twin && fabs(v + TWO_PI_ - s6) < fabs(v - s6))
        v += TWO_PI_;
    if (v < K.lo[5])
        v = K.lo[5];
    else if (v > K.hi[5])
        v = K.hi[5];
    return v;
}

static inline double
clampd(double x, double lo, double hi)
{
    return x < lo ? lo : (x > hi ? hi : x);
}

typedef struct {
    int shoulder_front;  /* 1 = front, 0 = back */
    double q1, rr, c1, s1;
} Shoulder;

/* The nearest in-limit solution for flange rotation r (row-major) and wrist centre p (m).
 * Returns 1 and fills best[6] (rad), or 0. */
static int
solve_best(const double r[9], const double p[3], const double s[6], int want_sh, int want_el,
           int want_fl, double best[6])
{
    const double r00 = r[0], r01 = r[1], r02 = r[2], r10 = r[3], r11 = r[4], r12 = r[5];
    const double r20 = r[6], r21 = r[7], r22 = r[8];
    const double x = p[0], y = p[1], z = p[2];
    const double s1 = s[0], s2 = s[1], s3 = s[2], s4 = s[3], s5 = s[4], s6 = s[5];
    double rho = sqrt(x * x + y * y);
    double Y = K.D1 - z;
    double best_d = INFINITY;
    int found = 0;
    Shoulder sh[2];
    int nsh;
    if (rho < K.shoulder_eps) {
        double q1f = clampd(s1, K.lo[0], K.hi[0]);
        /* Python: (shoulder or "front", ...): the pinned shoulder, else front */
        sh[0].shoulder_front = want_sh == 1 ? 0 : 1;
        sh[0].q1 = q1f; sh[0].rr = 0.0; sh[0].c1 = cos(q1f); sh[0].s1 = sin(q1f);
        nsh = 1;
    } else {
        double base = atan2(y, x);
        double c1f = x / rho, s1f = y / rho;
        double d = base - s1;
        Shoulder front = {1, base, rho, c1f, s1f};
        Shoulder back = {0, base + PI_, -rho, -c1f, -s1f};
        if (d > PI_ || d < -PI_)
            d -= TWO_PI_ * floor(d * K.INV_2PI + 0.5);
        if (-HALF_PI_ <= d && d <= HALF_PI_) {
            sh[0] = front; sh[1] = back;
        } else {
            sh[0] = back; sh[1] = front;
        }
        nsh = 2;
    }
    double de = s3 - K.PHI3;
    if (de > PI_ || de < -PI_)
        de -= TWO_PI_ * floor(de * K.INV_2PI + 0.5);
    /* elbow order: the seed's side of PHI3 first; code 0 = up (sign -1), 1 = down (+1) */
    const int el_code[2] = {de <= 0.0 ? 0 : 1, de <= 0.0 ? 1 : 0};
    for (int a = 0; a < nsh; a++) {
        if (want_sh >= 0 && (sh[a].shoulder_front ? 0 : 1) != want_sh)
            continue;
        double q1 = sh[a].q1;
        if (!fit(&q1, 0))
            continue;
        double e = q1 - s1;
        double d1 = K.w[0] * e * e;
        if (d1 >= best_d)
            continue;
        double X = sh[a].rr - K.A1;
        double c = (X * X + Y * Y - K.K0) * K.INV_2A2L;
        if (c > 1.0) {
            if (c > 1.0 + K.reach_eps)
                continue;
            c = 1.0;
        } else if (c < -1.0) {
            if (c < -1.0 - K.reach_eps)
                continue;
            c = -1.0;
        }
        double delta = acos(c);
        double atan_y = atan2(Y, X);
        double c1 = sh[a].c1, sn1 = sh[a].s1;
        double n00 = c1 * r00 + sn1 * r10;
        double n01 = c1 * r01 + sn1 * r11;
        double n02 = c1 * r02 + sn1 * r12;
        double n10 = c1 * r10 - sn1 * r00;
        double n12 = c1 * r12 - sn1 * r02;
        for (int b = 0; b < 2; b++) {
            int el = el_code[b];
            if (want_el >= 0 && el != want_el)
                continue;
            double q3 = K.PHI3_IN_RANGE + (el ? 1.0 : -1.0) * delta;
            if (!fit(&q3, 2))
                continue;
            e = q3 - s3;
            double d13 = d1 + K.w[2] * e * e;
            if (d13 >= best_d)
                continue;
            double c3 = cos(q3), sn3 = sin(q3);
            double q2 = atan_y - atan2(K.D4 * c3 - K.A3 * sn3, K.A2 + K.A3 * c3 + K.D4 * sn3);
            if (!fit(&q2, 1))
                continue;
            e = q2 - s2;
            double d123 = d13 + K.w[1] * e * e;
            if (d123 >= best_d)
                continue;
            double psi = q2 - q3;
            double cp = cos(psi), sp = sin(psi);
            double m02 = cp * n02 - sp * r22;
            double m22 = sp * n02 + cp * r22;
            double sb = sqrt(m02 * m02 + n12 * n12);
            if (sb > K.wrist_eps) {
                double be = atan2(sb, m22); /* (0, pi]: J5 = +be (noflip) or -be (flip) */
                if (be > K.hip[4])
                    continue;
                if (be > K.hi[4])
                    be = K.hi[4];
                double al = atan2(n12, m02);
                double ga = atan2(sp * n01 + cp * r21, -(sp * n00 + cp * r20));
                for (int f = 0; f < 2; f++) {
                    if (want_fl >= 0 && want_fl != f)
                        continue;
                    double q4 = f ? -al : PI_ - al;
                    double q5 = f ? -be : be;
                    double d;
                    if (fit(&q4, 3)) {
                        double e4 = q4 - s4;
                        double e5 = f ? be + s5 : be - s5;
                        d = d123 + K.w[3] * e4 * e4 + K.w[4] * e5 * e5;
                    } else {
                        d = INFINITY;
                    }
                    if (d < best_d) {
                        double q6 = fit6(f ? -ga : PI_ - ga, s6);
                        double e6 = q6 - s6;
                        d += K.w[5] * e6 * e6;
                        if (d < best_d) {
                            best_d = d;
                            best[0] = q1; best[1] = q2; best[2] = q3;
                            best[3] = q4; best[4] = q5; best[5] = q6;
                            found = 1;
                        }
                    }
                }
            } else {
                /* wrist singular: J4 keeps the seed's value, J6 takes the rest of J4 + J6 */
                if (m22 < 0)
                    continue; /* J5 = 180 deg */
                double q4 = clampd(s4, K.lo[3], K.hi[3]);
                double m00 = cp * n00 - sp * r20;
                double q6 = fit6(-atan2(n10, m00) - q4, s6);
                double e4 = q4 - s4, e6 = q6 - s6;
                double d = d123 + K.w[3] * e4 * e4 + K.w[4] * s5 * s5 + K.w[5] * e6 * e6;
                if (d < best_d) {
                    best_d = d;
                    best[0] = q1; best[1] = q2; best[2] = q3;
                    best[3] = q4; best[4] = 0.0; best[5] = q6;
                    found = 1;
                }
            }
        }
    }
    return found;
}

/* Six plain numbers (exact float / int, or subclasses of float such as numpy.float64) from a
 * list or tuple; 0 if the object is anything else (the Python path then decides). */
static int
six_numbers(PyObject *obj, double out[6])
{
    PyObject **items;
    if (PyList_CheckExact(obj)) {
        if (PyList_GET_SIZE(obj) != 6)
            return 0;
        items = ((PyListObject *)obj)->ob_item;
    } else if (PyTuple_CheckExact(obj)) {
        if (PyTuple_GET_SIZE(obj) != 6)
            return 0;
        items = ((PyTupleObject *)obj)->ob_item;
    } else {
        return 0;
    }
    for (int i = 0; i < 6; i++) {
        PyObject *it = items[i];
        if (PyFloat_Check(it)) {
            out[i] = PyFloat_AS_DOUBLE(it);
        } else if (PyLong_CheckExact(it)) {
            out[i] = PyLong_AsDouble(it);
            if (out[i] == -1.0 && PyErr_Occurred()) {
                PyErr_Clear(); /* too large for a float: the Python path reports it */
                return 0;
            }
        } else {
            return 0;
        }
    }
    return 1;
}

static PyObject *
cik_ik(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 7) {
        PyErr_Format(PyExc_TypeError, "ik() takes 7 arguments, got %zd", nargs);
        return NULL;
    }
    if (!K.ready) {
        PyErr_SetString(PyExc_RuntimeError, "parolkit _cik: configure() was not called");
        return NULL;
    }
    double pose[6], seed[6], tool[13];
    if (!six_numbers(args[0], pose))
        return PyLong_FromLong(-1);
    if (args[1] == Py_None) {
        for (int i = 0; i < 6; i++)
            seed[i] = K.standby[i];
    } else {
        if (!six_numbers(args[1], seed))
            return PyLong_FromLong(-1);
        for (int i = 0; i < 6; i++)
            seed[i] *= K.deg;
        /* the same finiteness test as ik.py's _seed() */
        if (!isfinite(seed[0] + seed[1] + seed[2] + seed[3] + seed[4] + seed[5]))
            return PyLong_FromLong(-1);
    }
    if (!PyTuple_CheckExact(args[2]) || PyTuple_GET_SIZE(args[2]) != 13) {
        PyErr_SetString(PyExc_TypeError, "ik(): tool must be a 13-tuple (Tool._native)");
        return NULL;
    }
    for (int i = 0; i < 13; i++) {
        tool[i] = PyFloat_AsDouble(PyTuple_GET_ITEM(args[2], i));
        if (tool[i] == -1.0 && PyErr_Occurred())
            return NULL;
    }
    long codes[3];
    for (int i = 0; i < 3; i++) {
        codes[i] = PyLong_AsLong(args[3 + i]);
        if (codes[i] == -1 && PyErr_Occurred())
            return NULL;
    }
    Py_buffer view;
    if (PyObject_GetBuffer(args[6], &view, PyBUF_WRITABLE | PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0)
        return NULL;
    if (view.len != 6 * (Py_ssize_t)sizeof(double) || view.format == NULL || strcmp(view.format, "d") != 0) {
        PyBuffer_Release(&view);
        PyErr_SetString(PyExc_TypeError, "ik(): out must be a writable buffer of 6 float64");
        return NULL;
    }
    /* pose -> rotation R = Rx(C) Ry(B) Rz(A) and position (m), as _target_flange() */
    double x = pose[0] * 1e-3, y = pose[1] * 1e-3, z = pose[2] * 1e-3;
    double a = pose[3] * K.deg, b = pose[4] * K.deg, c = pose[5] * K.deg;
    if (!isfinite(x + y + z + a + b + c)) {
        PyBuffer_Release(&view);
        return PyLong_FromLong(-1);
    }
    double ca = cos(a), sa = sin(a), cb = cos(b), sb = sin(b), cc = cos(c), sc = sin(c);
    double scsb = sc * sb, ccsb = cc * sb;
    double rot[9] = {cb * ca, -cb * sa, sb,
                     cc * sa + scsb * ca, cc * ca - scsb * sa, -sc * cb,
                     sc * sa - ccsb * ca, sc * ca + ccsb * sa, cc * cb};
    double rf[9];
    if (tool[0] != 0.0) {
        for (int i = 0; i < 9; i++)
            rf[i] = rot[i];
    } else { /* R_f = R T^T, summed in the order of ik.py's _flange_target */
        const double *t = tool + 1;
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                rf[3 * i + j] = rot[3 * i] * t[3 * j] + rot[3 * i + 1] * t[3 * j + 1] +
                                rot[3 * i + 2] * t[3 * j + 2];
    }
    double tx = tool[10], ty = tool[11], tz = tool[12];
    double pf[3] = {x - (rf[0] * tx + rf[1] * ty + rf[2] * tz),
                    y - (rf[3] * tx + rf[4] * ty + rf[5] * tz),
                    z - (rf[6] * tx + rf[7] * ty + rf[8] * tz)};
    double q[6];
    int ok = solve_best(rf, pf, seed, (int)codes[0], (int)codes[1], (int)codes[2], q);
    if (ok) {
        double *o = (double *)view.buf;
        for (int i = 0; i < 6; i++)
            o[i] = q[i] * K.rad;
    }
    PyBuffer_Release(&view);
    return PyLong_FromLong(ok);
}

static PyMethodDef cik_methods[] = {
    {"configure", (PyCFunction)cik_configure, METH_O,
     "configure(constants): the robot constants from parolkit.kinematics.ik (once, at import)."},
    {"ik", (PyCFunction)(void (*)(void))cik_ik, METH_FASTCALL,
     "ik(pose, seed, tool, shoulder, elbow, flip, out) -> 1 solved / 0 none / -1 not taken."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef cik_module = {
    PyModuleDef_HEAD_INIT, "_cik",
    "Compiled single-pose IK kernel of parolkit.kinematics (see ik.py, the reference).", -1,
    cik_methods,
};

PyMODINIT_FUNC
PyInit__cik(void)
{
    return PyModule_Create(&cik_module);
}
