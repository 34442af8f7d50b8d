"""The model build, on the host: a Scene into the constant arrays and struct fields the kernels read
(model, fields), the bodies' mass and rigidity, the joint types' table, integer codes, and the
mechanical energy of a state in NumPy."""
