"""Oracles of the contact tests: the barrier's resting distance (closed form of the barrier's
force, solved by bisection) and central differences of the contact terms."""

import math

import numpy as np

__all__ = ['resting_distance', 'contact_terms', 'assert_matches_differences', 'assert_psd']


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


def contact_terms(with_contact, without, q, q_tilde, step, row=0):
    """(gradient, Hessian, and their central differences with ``step``) of the contact terms
    alone at q (every body's state, (n_bodies, 12)) of a scene with one free body, in row
    ``row`` of q: the assembly of a scene with contact minus that of the same scene without
    (``Stages``)."""
    def gradient_at(x):
        return (with_contact.newton_system(x, q_tilde)[0]
                - without.newton_system(x, q_tilde)[0])

    def energy_at(x):
        return with_contact.energy(x, q_tilde) - without.energy(x, q_tilde)

    hessian = (with_contact.newton_system(q, q_tilde)[1]
               - without.newton_system(q, q_tilde)[1])
    fd_gradient, fd_hessian = np.zeros(12), np.zeros((12, 12))
    for i in range(12):
        e = np.zeros_like(q)
        e[row, i] = step
        fd_gradient[i] = (energy_at(q + e) - energy_at(q - e)) / (2 * step)
        fd_hessian[:, i] = (gradient_at(q + e) - gradient_at(q - e)) / (2 * step)
    return gradient_at(q), hessian, fd_gradient, fd_hessian


def assert_matches_differences(value, differences, rtol=1e-5, atol_share=1e-6):
    """``value`` (a gradient or Hessian) equals its central differences within ``rtol``, or
    ``atol_share`` of their largest entry."""
    np.testing.assert_allclose(value, differences, rtol=rtol,
                               atol=atol_share * np.abs(differences).max())


def assert_psd(hessian):
    """The symmetric part of ``hessian`` has no eigenvalue below −1e-9 of its largest entry."""
    assert np.linalg.eigvalsh(0.5 * (hessian + hessian.T)).min() > -1e-9 * np.abs(hessian).max()
