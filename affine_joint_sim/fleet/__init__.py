"""Many jobs at once: ``affine-joint-sim replay BAG... --workers N | --ray ADDRESS --report
FILE`` re-simulates every bag in parallel and reports per bag; ``affine-joint-sim sweep SPEC``
runs the bench's speed/accuracy sweep over a declared grid the same way. Both stop, with
their workers, on Ctrl-C or SIGTERM (``stopping``)."""
