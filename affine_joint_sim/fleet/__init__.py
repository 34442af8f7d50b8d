"""Many bags at once (the scale-out issue): ``affine-joint-sim replay BAG... --workers N |
--ray ADDRESS --report FILE`` re-simulates every bag in parallel and reports per bag."""
