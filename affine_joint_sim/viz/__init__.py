"""What a run looks like: the shapes of a scene's bodies (``drawables``), the robot description
of any scene (``description``), and pictures of a recorded run (``render``)."""
