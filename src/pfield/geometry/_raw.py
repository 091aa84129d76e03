"""Reference-count-free array views for compiled hot paths (numba intrinsics).

Numba reference-counts every array it hands to a function it does not inline, with atomic
increments of ~5 ns each, and a call taking arrays also stops it from pruning the counts of the
caller's loop. The signed-distance dispatch is inlined into consumers' loops, so its mesh branch
passes the BVH query raw addresses (``arr.ctypes.data``) and the query rebuilds views with
:func:`numba.carray`. The caller keeps the owning arrays alive for the duration of the call; the arrays
must be C-contiguous (``pack_obstacles`` guarantees it).
"""

from __future__ import annotations

from typing import Any

from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

STACK_SIZE = 96


def _float_pointer(typingctx: Any, address: Any) -> Any:
    signature = types.CPointer(types.float64)(address)

    def codegen(context: Any, builder: Any, sig: Any, args: Any) -> Any:
        return builder.inttoptr(args[0], context.get_value_type(types.CPointer(types.float64)))

    return signature, codegen


def _int_pointer(typingctx: Any, address: Any) -> Any:
    signature = types.CPointer(types.int64)(address)

    def codegen(context: Any, builder: Any, sig: Any, args: Any) -> Any:
        return builder.inttoptr(args[0], context.get_value_type(types.CPointer(types.int64)))

    return signature, codegen


def _stack_buffer(typingctx: Any) -> Any:
    signature = types.CPointer(types.int64)()

    def codegen(context: Any, builder: Any, sig: Any, args: Any) -> Any:
        return cgutils.alloca_once(builder, context.get_value_type(types.int64), size=STACK_SIZE)

    return signature, codegen


float_pointer: Any = intrinsic(_float_pointer)
"""``float_pointer(address)``: the ``float64*`` at an integer address (compiled code only)."""
int_pointer: Any = intrinsic(_int_pointer)
"""``int_pointer(address)``: the ``int64*`` at an integer address (compiled code only)."""
stack_buffer: Any = intrinsic(_stack_buffer)
"""``stack_buffer()``: ``int64*`` to ``STACK_SIZE`` int64 on the call stack (``alloca`` in the entry block)."""
