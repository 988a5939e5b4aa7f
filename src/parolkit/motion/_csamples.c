/* Compiled sample fill of a synchronised joint move: the hot path of MoveJoint planning.
 *
 * A poly / trap joint move is q(t) = start + s(t) * delta with one unit profile s(t) shared
 * by the six joints.  planner.py's _monotonic_trajectory() builds its arrays with numpy
 * (the reference, and what runs when this module is not built or PAROLKIT_PURE_PYTHON=1);
 * this kernel fills the same three arrays in one pass instead of about ten numpy calls.
 * tests/unit/test_motion_native.py checks both produce the same trajectories.
 *
 *   fill(basis, speed, start, target, spd) -> (q, pos, sp), three new read-only arrays
 *       basis:  (N, 2) float64, columns 1 and s(t)      (profiles.sampled_basis)
 *       speed:  (N, 1) float64, s'(t), last value 0      (profiles.sampled_basis)
 *       start, target, spd: 6 floats each (deg, deg, steps/deg), lists or tuples;
 *       delta = target - start
 *       q:   (N, 6) float64: joint angles (deg), the last row exactly the target
 *       pos: (N, 6) int64: positions in steps, rint(start*spd + s*(delta*spd)),
 *            the last row rint(target*spd)
 *       sp:  (N, 6) int64: speeds in steps/s, rint(s' * (delta*spd))
 * Rounding is to nearest, ties to even (numpy.rint): llrint in the default rounding mode.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#define NPY_NO_DEPRECATED_API NPY_1_22_API_VERSION
#define NPY_TARGET_VERSION NPY_1_22_API_VERSION
#include <numpy/arrayobject.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

static int
six_floats(PyObject *obj, const char *name, double out[6])
{
    PyObject *seq = PySequence_Fast(obj, name);
    if (seq == NULL)
        return 0;
    if (PySequence_Fast_GET_SIZE(seq) != 6) {
        PyErr_Format(PyExc_ValueError, "fill(): %s must have 6 values", name);
        Py_DECREF(seq);
        return 0;
    }
    for (int i = 0; i < 6; i++) {
        out[i] = PyFloat_AsDouble(PySequence_Fast_GET_ITEM(seq, i));
        if (out[i] == -1.0 && PyErr_Occurred()) {
            Py_DECREF(seq);
            return 0;
        }
    }
    Py_DECREF(seq);
    return 1;
}

/* A C-contiguous buffer of `count` items of format `fmt` ("d" or an 8-byte integer). */
static int
get_buffer(PyObject *obj, Py_buffer *view, int writable, int integer, Py_ssize_t count,
           const char *name)
{
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(obj, view, flags) < 0)
        return 0;
    const char *f = view->format ? view->format : "B";
    if (*f == '<' || *f == '=' || *f == '@')
        f++;
    int ok = view->itemsize == 8 &&
             (integer ? (strcmp(f, "l") == 0 || strcmp(f, "q") == 0) : strcmp(f, "d") == 0) &&
             (count < 0 || view->len == count * 8);
    if (!ok) {
        PyErr_Format(PyExc_TypeError, "fill(): %s must be a C-contiguous %s array%s", name,
                     integer ? "int64" : "float64", count < 0 ? "" : " of the right size");
        PyBuffer_Release(view);
        return 0;
    }
    return 1;
}

/* The three arrays of q = start + s * delta (see the header).  restrict: the outputs are
 * fresh arrays, distinct from the inputs, so the compiler may keep inputs in registers and
 * vectorise the stores. */
#if defined(_MSC_VER)
#define restrict __restrict
#endif

static void
fill_arrays(const double *restrict basis, const double *restrict speed,
            const double *restrict start, const double *restrict delta,
            const double *restrict target, const double *restrict spd, double *restrict q,
            int64_t *restrict pos, int64_t *restrict sp, Py_ssize_t n)
{
    double s0[6], sd[6];
    for (int j = 0; j < 6; j++) {
        s0[j] = start[j] * spd[j];
        sd[j] = delta[j] * spd[j];
    }
    for (Py_ssize_t i = 0; i < n - 1; i++) {
        double s = basis[2 * i + 1], ds = speed[i];
        double *qi = q + 6 * i;
        int64_t *pi = pos + 6 * i, *si = sp + 6 * i;
        for (int j = 0; j < 6; j++) {
            qi[j] = start[j] + s * delta[j];
            pi[j] = (int64_t)llrint(s0[j] + s * sd[j]);
            si[j] = (int64_t)llrint(ds * sd[j]);
        }
    }
    {
        Py_ssize_t i = n - 1;
        double ds = speed[i];
        for (int j = 0; j < 6; j++) {
            q[6 * i + j] = target[j];
            pos[6 * i + j] = (int64_t)llrint(target[j] * spd[j]);
            sp[6 * i + j] = (int64_t)llrint(ds * sd[j]);
        }
    }
}

static PyObject *
cs_fill(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (nargs != 5) {
        PyErr_Format(PyExc_TypeError, "fill() takes 5 arguments, got %zd", nargs);
        return NULL;
    }
    double start[6], delta[6], target[6], spd[6];
    if (!six_floats(args[2], "start", start) || !six_floats(args[3], "target", target) ||
        !six_floats(args[4], "spd", spd))
        return NULL;
    for (int j = 0; j < 6; j++)
        delta[j] = target[j] - start[j];
    Py_buffer b, v;
    if (!get_buffer(args[0], &b, 0, 0, -1, "basis"))
        return NULL;
    Py_ssize_t n = b.len / 16;
    if (n < 1 || b.len != n * 16) {
        PyBuffer_Release(&b);
        PyErr_SetString(PyExc_ValueError, "fill(): basis must be (N, 2) with N >= 1");
        return NULL;
    }
    if (!get_buffer(args[1], &v, 0, 0, n, "speed")) {
        PyBuffer_Release(&b);
        return NULL;
    }
    npy_intp dims[2] = {n, 6};
    PyArrayObject *q = (PyArrayObject *)PyArray_SimpleNew(2, dims, NPY_FLOAT64);
    PyArrayObject *pos = (PyArrayObject *)PyArray_SimpleNew(2, dims, NPY_INT64);
    PyArrayObject *sp = (PyArrayObject *)PyArray_SimpleNew(2, dims, NPY_INT64);
    PyObject *out = NULL;
    if (q != NULL && pos != NULL && sp != NULL) {
        fill_arrays((const double *)b.buf, (const double *)v.buf, start, delta, target, spd,
                    (double *)PyArray_DATA(q), (int64_t *)PyArray_DATA(pos),
                    (int64_t *)PyArray_DATA(sp), n);
        PyArray_CLEARFLAGS(q, NPY_ARRAY_WRITEABLE);
        PyArray_CLEARFLAGS(pos, NPY_ARRAY_WRITEABLE);
        PyArray_CLEARFLAGS(sp, NPY_ARRAY_WRITEABLE);
        out = PyTuple_Pack(3, (PyObject *)q, (PyObject *)pos, (PyObject *)sp);
    }
    Py_XDECREF(q);
    Py_XDECREF(pos);
    Py_XDECREF(sp);
    PyBuffer_Release(&b);
    PyBuffer_Release(&v);
    return out;
}

static PyMethodDef cs_methods[] = {
    {"fill", (PyCFunction)(void (*)(void))cs_fill, METH_FASTCALL,
     "fill(basis, speed, start, target, spd) -> (q, pos, sp): the read-only arrays of a "
     "synchronised joint move (see joint._fill_reference, the reference)."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef cs_module = {
    PyModuleDef_HEAD_INIT, "_csamples",
    "Compiled sample fill of parolkit.motion joint moves (see planner.py, the reference).", -1,
    cs_methods, NULL, NULL, NULL, NULL,
};

PyMODINIT_FUNC
PyInit__csamples(void)
{
    import_array(); /* numpy's C API; an ImportError here makes parolkit use the reference */
    return PyModule_Create(&cs_module);
}
