"""Bitwise agreement: which operations a compiled kernel computes as the interpreted step does, bit
for bit (``reference._kernels``): IEEE arithmetic and square root in the source's order, exact
abs/min/max, making arrays, and the library functions this machine's numpy and numba are checked
to agree on; anything else keeps the pair's accuracy runs interpreted (``reference._compiled.bitwise_why``)."""

from __future__ import annotations

import ast


#: Calls whose result numba computes bit for bit as numpy and Python do: IEEE 754's correctly
#: rounded square root, the exact abs, min and max, and making arrays.
BITWISE_CALLS = frozenset(
    {
        "np.sqrt",
        "math.sqrt",
        "np.abs",
        "abs",
        "min",
        "max",
        "np.empty_like",
        "np.zeros_like",
        "np.empty",
        "np.zeros",
        "np.eye",
        "np.outer",
        "np.ascontiguousarray",
        "range",
        "len",
        "float",
        "int",
    }
)
#: Array methods likewise computed bit for bit.
BITWISE_METHODS = frozenset({"copy"})
#: Functions both sides take from a library: the C library's sin, cos and exp (where numpy does
#: not bring its own vectorised version) and LAPACK's dense solve (numpy's bundled build against
#: the one numba calls through scipy): the same bits exactly where this machine's builds agree
#: on them (``reference._libm.agrees``, checked once per process).
LIBM_CALLS = frozenset({"np.sin", "np.cos", "np.exp", "math.sin", "math.cos", "math.exp", "np.linalg.solve"})


def bitwise_why(tree: ast.FunctionDef, modules: dict[str, str], known: set[str], libm: set[str]) -> str:
    """Why numba might compute other bits than the interpreted function ``tree``, or "".

    Interpreted, a kernel runs numpy's elementwise operations and Python's float arithmetic;
    compiled, numba's. Both round every +, -, *, / and sqrt as IEEE 754 says, in the order the
    source writes them (numba neither reassociates nor contracts a*b + c into one rounding
    without fastmath, which the kernels do not ask for), so a function built only of those,
    of exact operations and of calls to other such functions computes the same bits either
    way. A reduction (np.sum, np.dot, @: numpy sums pairwise, numba in order), ``**`` (numpy's
    pow against numba's repeated products) or any call not listed might not; a library
    function (``LIBM_CALLS``) does where the machine's builds agree. ``modules`` maps the names bound to numpy and
    math to "np" and "math"; ``known``: functions and kernels of the file (bitwise if their own source is);
    the libm functions called are added to ``libm``."""
    for node in ast.walk(tree):
        if isinstance(node, (ast.BinOp, ast.AugAssign)) and isinstance(node.op, (ast.Pow, ast.MatMult)):
            return f"uses {'**' if isinstance(node.op, ast.Pow) else '@'}"
        if not isinstance(node, ast.Call):
            continue
        func = node.func
        if isinstance(func, ast.Name):
            name = func.id
            if name in known or name in BITWISE_CALLS:
                continue
            return f"calls {name}"
        root, path = func, []
        while isinstance(root, ast.Attribute):
            path.insert(0, root.attr)
            root = root.value
        if path and isinstance(root, ast.Name) and root.id in modules:
            name = ".".join([modules[root.id], *path])
            if name in BITWISE_CALLS:
                continue
            if name in LIBM_CALLS:
                libm.add(name)
                continue
            return f"calls {name}"
        if isinstance(func, ast.Attribute) and func.attr in BITWISE_METHODS:
            continue
        return f"calls {ast.unparse(func)}"
    return ""
