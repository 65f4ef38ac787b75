"""The reference schemes, one file each: the step function with its update formulas in its
docstring, and declared with it its order, force evaluations, symplecticity, stability limit, its
floor, its recurrence on the damped oscillator and the scenes it joins in the standard suite
(``reference._scheme.scheme``); or a splitting declared as its drifts and kicks
(``reference.splitting``), or a scheme substepped (``reference.substepped``), from which the step,
floor, recurrence and claims follow. ``reference.METHODS`` lists them."""
