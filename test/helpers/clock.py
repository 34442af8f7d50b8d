"""A wall clock the test sets by hand (for Pacer and LockstepGate)."""


class FakeClock:
    def __init__(self, now=100.0):
        self.now = now

    def __call__(self):
        return self.now
