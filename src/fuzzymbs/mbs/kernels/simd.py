"""Float64 vectors of LANES lanes for Numba kernels: one LLVM ``<LANES x double>`` per value.

Numba gives no SIMD type, and LLVM's loop vectoriser leaves the lockstep
kernels (:mod:`fuzzymbs.mbs.kernels`) scalar: their arrays may alias and Numba
cannot say otherwise (docs/embs.md, "Samples in lockstep"). This module
declares the vector type directly, so that every operation on it *is* one
vector instruction (AVX2 at 4 lanes, AVX-512 at 8), whatever the aliasing:

* :func:`load` / :func:`store`: :data:`LANES` consecutive float64 of a C-contiguous
  1-d array (lane-minor layout: element ``i`` of lane ``l`` at ``LANES i + l``), or
  of a C-ordered array of any dimension at a flat index (an (N, LANES) array's row
  ``i`` at ``LANES i``);
* :func:`splat`, :func:`broadcast`, :func:`insert`, :func:`get`: build and read
  vectors; :func:`all_zero`, :func:`same_lanes`: tests over the lanes;
* ``+ - * /`` and unary ``-`` between vectors and with scalars, :func:`fma`,
  :func:`sqrt`, :func:`floor`, :func:`vabs`;
* selects ``where_lt(a, b, x, y) = a < b ? x : y`` (per lane) and friends, so
  that branches become masks.

:data:`LANES` is fixed at import: 4, or ``FUZZYMBS_LANES=8`` (AVX-512). Every lane
does the same per-element operations at either width, so a sample's results are bit
for bit the same; 8 lanes make large RK4 batches cheaper but single-sample blocks
(a shared-step study's modal and reference runs) dearer, and a default study slower
(docs/benchmarks.md, "Lane width"). Numba's on-disk caches hold one width:
:func:`check_cache` (run at import) stops a process whose cached kernels were
compiled for the other one.

Inside ``@njit(fastmath=...)`` functions Numba's fast-math pass flags these
operations like scalar ones. Inputs outside the array are not checked: the
callers index within their own work arrays.
"""

from __future__ import annotations

import operator
import os

import numba as nb
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic, models, overload, register_model


def choose_lanes() -> int:
    """``FUZZYMBS_LANES`` (4 or 8) if set, else 4."""
    value = os.environ.get("FUZZYMBS_LANES", "").strip()
    if value in ("4", "8"):
        return int(value)
    if value:
        raise ValueError(f"FUZZYMBS_LANES must be 4 or 8, not {value!r}")
    return 4


#: samples per vector, fixed at import (:func:`choose_lanes`)
LANES = choose_lanes()
# Fast-math flags of the kernels: reassociation and FMA contraction; NaN/inf semantics
# are kept (no 'nnan'/'ninf') so that blown-up samples are still detected.
FAST = {"reassoc", "contract", "arcp"}
# Kernels called at every step that allocate nothing take ``_nrt=NO_REFCOUNT``: without
# Numba's reference counting, taking a work tuple apart or slicing a pool costs no atomic
# increment and decrement (about 140 pairs per brake right-hand side, 5 % of its time:
# docs/benchmarks.md). Their callees inherit it, and an allocation in any of them is then
# a compile error, not a leak.
NO_REFCOUNT = False


class Vec4Type(types.Type):
    """Numba type of a float64 vector of :data:`LANES` lanes (named for the first width)."""

    def __init__(self) -> None:
        super().__init__(name="Vec4")


vec4 = Vec4Type()
_VECTOR = ir.VectorType(ir.DoubleType(), LANES)
_I32 = ir.IntType(32)


@register_model(Vec4Type)
class _Vec4Model(models.PrimitiveModel):
    def __init__(self, dmm, fe_type):
        super().__init__(dmm, fe_type, _VECTOR)


def _element_pointer(context, builder, arytype, ary, index):
    data = context.make_array(arytype)(context, builder, ary).data
    return builder.bitcast(builder.gep(data, [index]), _VECTOR.as_pointer())


def _is_float_array(arr) -> bool:
    if not (isinstance(arr, types.Array) and arr.dtype == types.float64):
        return False
    return arr.ndim == 1 or arr.layout == "C"  # a flat index into an n-d array needs C order


@intrinsic
def load(typingctx, arr, index):
    """``arr[index : index + LANES]`` as a vector (1-d C-contiguous float64 array)."""
    if not (_is_float_array(arr) and isinstance(index, types.Integer)):
        return None

    def codegen(context, builder, sig, args):
        return builder.load(_element_pointer(context, builder, sig.args[0], *args), align=8)

    return vec4(arr, index), codegen


@intrinsic
def store(typingctx, arr, index, value):
    """``arr[index : index + LANES] = value``."""
    if not (_is_float_array(arr) and isinstance(index, types.Integer) and value == vec4):
        return None

    def codegen(context, builder, sig, args):
        pointer = _element_pointer(context, builder, sig.args[0], args[0], args[1])
        builder.store(args[2], pointer, align=8)
        return context.get_dummy_value()

    return types.none(arr, index, value), codegen


@intrinsic
def splat(typingctx, x):
    """Every lane equal to the scalar x."""
    if not isinstance(x, (types.Float, types.Integer)):
        return None

    def codegen(context, builder, sig, args):
        value = context.cast(builder, args[0], sig.args[0], types.float64)
        vector = ir.Constant(_VECTOR, ir.Undefined)
        for k in range(LANES):
            vector = builder.insert_element(vector, value, ir.Constant(_I32, k))
        return vector

    return vec4(x), codegen


@intrinsic
def broadcast(typingctx, arr, index):
    """Every lane equal to ``arr[index]`` (no negative-index wrap-around: index >= 0)."""
    if not (_is_float_array(arr) and isinstance(index, types.Integer)):
        return None

    def codegen(context, builder, sig, args):
        data = context.make_array(sig.args[0])(context, builder, args[0]).data
        value = builder.load(builder.gep(data, [args[1]]), align=8)
        vector = ir.Constant(_VECTOR, ir.Undefined)
        for k in range(LANES):
            vector = builder.insert_element(vector, value, ir.Constant(_I32, k))
        return vector

    return vec4(arr, index), codegen


@intrinsic
def insert(typingctx, v, lane, x):
    """v with lane ``lane`` set to the scalar x."""
    if not (v == vec4 and isinstance(lane, types.Integer)):
        return None
    if not isinstance(x, (types.Float, types.Integer)):
        return None

    def codegen(context, builder, sig, args):
        value = context.cast(builder, args[2], sig.args[2], types.float64)
        return builder.insert_element(args[0], value, args[1])

    return vec4(v, lane, x), codegen


def _all_set(builder, mask):
    # the L-bit mask as one integer: every lane true
    bits = builder.bitcast(mask, ir.IntType(LANES))
    return builder.icmp_unsigned("==", bits, ir.Constant(ir.IntType(LANES), (1 << LANES) - 1))


@intrinsic
def all_zero(typingctx, v):
    """True if every lane of v equals 0.0 (a NaN lane does not)."""
    if v != vec4:
        return None

    def codegen(context, builder, sig, args):
        zero = ir.Constant(_VECTOR, [ir.Constant(ir.DoubleType(), 0.0)] * LANES)
        return _all_set(builder, builder.fcmp_ordered("==", args[0], zero))

    return types.boolean(v), codegen


@intrinsic
def same_lanes(typingctx, v):
    """True if every lane of v equals lane 0 (none if lane 0 is NaN)."""
    if v != vec4:
        return None

    def codegen(context, builder, sig, args):
        first = ir.Constant(ir.VectorType(_I32, LANES), [ir.Constant(_I32, 0)] * LANES)
        spread = builder.shuffle_vector(args[0], ir.Constant(_VECTOR, ir.Undefined), first)
        return _all_set(builder, builder.fcmp_ordered("==", args[0], spread))

    return types.boolean(v), codegen


@intrinsic
def get(typingctx, v, lane):
    """Lane ``lane`` of v as a scalar."""
    if v != vec4 or not isinstance(lane, types.Integer):
        return None

    def codegen(context, builder, sig, args):
        return builder.extract_element(args[0], args[1])

    return types.float64(v, lane), codegen


def _binary(instruction: str):
    @intrinsic
    def op(typingctx, a, b):
        if a != vec4 or b != vec4:
            return None

        def codegen(context, builder, sig, args):
            return getattr(builder, instruction)(args[0], args[1])

        return vec4(a, b), codegen

    return op


_add = _binary("fadd")
_sub = _binary("fsub")
_mul = _binary("fmul")
_div = _binary("fdiv")


def _llvm_call(name: str, n_args: int):
    def codegen(context, builder, sig, args):
        fnty = ir.FunctionType(_VECTOR, [_VECTOR] * n_args)
        fn = cgutils.get_or_insert_function(builder.module, fnty, name)
        return builder.call(fn, list(args))

    return codegen


@intrinsic
def fma(typingctx, a, b, c):
    """a * b + c with one rounding."""
    if not (a == vec4 and b == vec4 and c == vec4):
        return None
    return vec4(a, b, c), _llvm_call(f"llvm.fma.v{LANES}f64", 3)


@intrinsic
def sqrt(typingctx, a):
    """Square root per lane."""
    if a != vec4:
        return None
    return vec4(a), _llvm_call(f"llvm.sqrt.v{LANES}f64", 1)


@intrinsic
def floor(typingctx, a):
    """Largest integer <= a, per lane (as float64)."""
    if a != vec4:
        return None
    return vec4(a), _llvm_call(f"llvm.floor.v{LANES}f64", 1)


@intrinsic
def vabs(typingctx, a):
    """Absolute value per lane."""
    if a != vec4:
        return None
    return vec4(a), _llvm_call(f"llvm.fabs.v{LANES}f64", 1)


def _select(predicate: str):
    @intrinsic
    def op(typingctx, a, b, x, y):
        if not (a == vec4 and b == vec4 and x == vec4 and y == vec4):
            return None

        def codegen(context, builder, sig, args):
            mask = builder.fcmp_ordered(predicate, args[0], args[1])
            return builder.select(mask, args[2], args[3])

        return vec4(a, b, x, y), codegen

    return op


#: ``where_lt(a, b, x, y)``: x where a < b, else y (a NaN lane takes y).
where_lt = _select("<")
#: x where a <= b, else y.
where_le = _select("<=")
#: x where a == b, else y.
where_eq = _select("==")


def _overload_arithmetic(opfunc, vector_op) -> None:
    def typer(a, b):
        if isinstance(a, Vec4Type) and isinstance(b, Vec4Type):
            return lambda a, b: vector_op(a, b)
        if isinstance(a, Vec4Type) and isinstance(b, (types.Float, types.Integer)):
            return lambda a, b: vector_op(a, splat(b))
        if isinstance(b, Vec4Type) and isinstance(a, (types.Float, types.Integer)):
            return lambda a, b: vector_op(splat(a), b)
        return None

    overload(opfunc)(typer)


for _opfunc, _vector_op in (
    (operator.add, _add),
    (operator.sub, _sub),
    (operator.mul, _mul),
    (operator.truediv, _div),
    # x += y on a vector binds x to a new value, as on a float
    (operator.iadd, _add),
    (operator.isub, _sub),
    (operator.imul, _mul),
    (operator.itruediv, _div),
):
    _overload_arithmetic(_opfunc, _vector_op)


@overload(operator.neg)
def _neg(a):
    if isinstance(a, Vec4Type):
        return lambda a: _sub(splat(0.0), a)
    return None


@nb.njit(cache=True)
def _cached_lanes():
    return LANES  # frozen into the cached machine code with the kernels


def check_cache() -> None:
    """Raise if Numba's on-disk cache holds code of the other lane count.

    The cache is keyed by the source files and the CPU, not by :data:`LANES`, so
    kernels cached at one width would be loaded at the other (and write past their
    arrays). The check reads this module's own cached function: it catches a switch
    of ``FUZZYMBS_LANES``, not an edit of this file (delete the caches then too).

    Raises
    ------
    RuntimeError
        With the command that deletes the caches.
    """
    cached = _cached_lanes()
    if cached != LANES:
        raise RuntimeError(
            f"Numba's cache holds the kernels for {cached} lanes, this process runs "
            f"{LANES} (FUZZYMBS_LANES): delete the caches (find <checkout> -name "
            "'*.nb[ic]' -delete) or give each width its own NUMBA_CACHE_DIR"
        )


check_cache()
