"""The barrier's resting distance, the oracle of the contact tests (closed form of the
barrier's force, solved by bisection)."""

import math

__all__ = ['resting_distance']


def resting_distance(force, d_hat, kappa):
    """d* with −d b'(d²)·2 = force (the barrier's normal force, no dt²), by bisection."""
    big_hat = d_hat * d_hat

    def normal_force(d):
        big = d * d
        return 2.0 * kappa * d * (2.0 * (big - big_hat) * math.log(big / big_hat)
                                  + (big - big_hat) ** 2 / big)

    low, high = 1e-12, d_hat
    for _ in range(200):
        mid = 0.5 * (low + high)
        low, high = (mid, high) if normal_force(mid) > force else (low, mid)
    return 0.5 * (low + high)
