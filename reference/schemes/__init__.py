"""The reference schemes, one file each: the step function with its update formulas in its
docstring, and declared with it its order, force evaluations, symplecticity, stability limit, its
floor, its recurrence on the damped oscillator and the scenes it joins in the standard suite
(``reference._scheme.scheme``). ``reference.METHODS`` lists them."""
