"""The reference schemes, one file each: the step function with its update formulas in its
docstring and its declared order, force evaluations, symplecticity and stability limit
(``reference._scheme.scheme``). ``reference.METHODS`` lists them."""
