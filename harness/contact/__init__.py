"""Contact: the engines' ball, slide, rest and stack against their analytic truth (``figures``,
``run``), and the reference schemes on a penalty ground (``penalty``)."""
