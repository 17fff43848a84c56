"""Pure controllers: no I/O, no clocks; ``dt`` is an input."""
