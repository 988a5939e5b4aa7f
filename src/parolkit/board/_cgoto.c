/* Compiled GO TO passes of the board emulator: the hot path of a fast-forwarded run.
 *
 * Between two frames the emulated board runs its GO TO law once a pass on every joint (20
 * passes a 100 Hz frame at the default 2 kHz).  emulator.py's goto_passes() is the reference:
 * it is what runs when this module is not built (no C compiler) or PAROLKIT_PURE_PYTHON=1.
 * This is the same arithmetic, in the same order and in the same IEEE double precision
 * (built with -ffp-contract=off: no fused multiply-add), so the counters, speeds and sub-step
 * phases come out bit for bit the same; tests/unit/test_board_emulator_passes.py checks both
 * against the per-pass loop they replaced.
 *
 *   passes(n, dt, clamp, counters, phases, targets, feed_forwards)
 *       -> (counters, phases, speeds, settled)
 *       n: passes (>= 1); dt: s a pass; clamp: the firmware's speed clamp, steps/s
 *       counters, targets, feed_forwards: 6 ints each; phases: 6 floats (sub-step phases)
 *       settled: every joint's speed came out 0 within the n passes
 *   Per joint and pass: v = int(((target - counter) / 0.01 + v_ff) / 2), clamped to +-clamp;
 *   a joint whose v is 0 stops there; else phase += v * dt, the whole steps of the phase
 *   move the counter.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>

static int
six_ll(PyObject *obj, const char *name, long long out[6])
{
    if (!PyTuple_Check(obj) || PyTuple_GET_SIZE(obj) != 6) {
        PyErr_Format(PyExc_TypeError, "passes(): %s must be a tuple of 6 ints", name);
        return 0;
    }
    for (int i = 0; i < 6; i++) {
        out[i] = PyLong_AsLongLong(PyTuple_GET_ITEM(obj, i));
        if (out[i] == -1 && PyErr_Occurred())
            return 0;
    }
    return 1;
}

static int
six_d(PyObject *obj, const char *name, double out[6])
{
    if (!PyTuple_Check(obj) || PyTuple_GET_SIZE(obj) != 6) {
        PyErr_Format(PyExc_TypeError, "passes(): %s must be a tuple of 6 floats", name);
        return 0;
    }
    for (int i = 0; i < 6; i++) {
        out[i] = PyFloat_AsDouble(PyTuple_GET_ITEM(obj, i));
        if (out[i] == -1.0 && PyErr_Occurred())
            return 0;
    }
    return 1;
}

static PyObject *
passes(PyObject *self, PyObject *args)
{
    long long n, clamp;
    double dt;
    PyObject *counters_o, *phases_o, *targets_o, *ff_o;
    long long c[6], tgt[6], ff[6], speed[6];
    double acc[6];
    if (!PyArg_ParseTuple(args, "LdLOOOO", &n, &dt, &clamp, &counters_o, &phases_o, &targets_o, &ff_o))
        return NULL;
    if (n < 1) {
        PyErr_SetString(PyExc_ValueError, "passes(): n must be >= 1");
        return NULL;
    }
    if (!six_ll(counters_o, "counters", c) || !six_d(phases_o, "phases", acc)
            || !six_ll(targets_o, "targets", tgt) || !six_ll(ff_o, "feed_forwards", ff))
        return NULL;
    const double hi = (double)clamp, lo = -(double)clamp;
    int settled = 1;
    for (int j = 0; j < 6; j++) {
        long long cj = c[j], v = 0;
        double a = acc[j];
        long long i;
        for (i = 0; i < n; i++) {
            /* Python: int(((tgt - c) / 0.01 + vff) / 2), then the clamp on the int */
            double x = trunc(((double)(tgt[j] - cj) / 0.01 + (double)ff[j]) / 2);
            if (x > hi)
                v = clamp;
            else if (x < lo)
                v = -clamp;
            else
                v = (long long)x;
            if (v == 0)
                break;
            a = a + (double)v * dt;
            long long k = (long long)a;
            a = a - (double)k;
            cj += k;
        }
        if (i == n)
            settled = 0;
        c[j] = cj;
        acc[j] = a;
        speed[j] = v;
    }
    PyObject *co = PyTuple_New(6), *ao = PyTuple_New(6), *so = PyTuple_New(6);
    if (co == NULL || ao == NULL || so == NULL)
        goto fail;
    for (int j = 0; j < 6; j++) {
        PyObject *ci = PyLong_FromLongLong(c[j]), *ai = PyFloat_FromDouble(acc[j]);
        PyObject *si = PyLong_FromLongLong(speed[j]);
        if (ci == NULL || ai == NULL || si == NULL) {
            Py_XDECREF(ci);
            Py_XDECREF(ai);
            Py_XDECREF(si);
            goto fail;
        }
        PyTuple_SET_ITEM(co, j, ci);
        PyTuple_SET_ITEM(ao, j, ai);
        PyTuple_SET_ITEM(so, j, si);
    }
    return Py_BuildValue("(NNNO)", co, ao, so, settled ? Py_True : Py_False);
fail:
    Py_XDECREF(co);
    Py_XDECREF(ao);
    Py_XDECREF(so);
    return NULL;
}

static PyMethodDef methods[] = {
    {"passes", passes, METH_VARARGS,
     "passes(n, dt, clamp, counters, phases, targets, feed_forwards) -> "
     "(counters, phases, speeds, settled): n GO TO passes of the six joints"},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_cgoto",
    "Compiled GO TO passes of the board emulator (reference: parolkit.board.emulator.goto_passes).",
    -1, methods,
};

PyMODINIT_FUNC
PyInit__cgoto(void)
{
    return PyModule_Create(&module);
}
