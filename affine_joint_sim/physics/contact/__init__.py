"""Contact, one folder per job (docs/architecture.md#adding-a-contact-primitive).

The kinds (``kinds``: static shape kinds, families of pairs between moving bodies), then the
host's model build, NumPy: a fixed body's shapes and mesh triangles (``shapes``, ``mesh``),
a moving mesh's hull (``hull``), the edges and faces of both (``primitives``), the contact
arrays of the model (``model``) and the pairs' numbering, reference distances and near list
(``pairs``); then the kernel, Warp: each pair's distance (``geometry``), the barrier,
friction and damping terms, the near list and the step bound (``terms``), and the contact
report read after a step (``report``).
"""
