"""One bag re-simulated, as a job any worker can run: plain arguments in, a plain dict out
(picklable for process pools and Ray), never an exception: whatever goes wrong with a bag is
its result's error. Executors run it through ``worker.run_job`` (Warp quiet, warnings
returned)."""

import time

__all__ = ['replay_job', 'failed_result', 'STATUS']

# pass: within tol; fail: diverged beyond it; error: the bag could not be read or replayed
STATUS = ('pass', 'fail', 'error')


def failed_result(bag, why: str) -> dict:
    """The result of a bag that could not be replayed: status 'error' and why."""
    return {'bag': str(bag), 'status': 'error', 'states': 0, 'max_angle': float('nan'),
            'max_velocity': float('nan'), 'worst': float('nan'), 'seconds': 0.0, 'error': why}


def replay_job(bag: str, tol: float, scene: str | None = None, device: str = 'cpu') -> dict:
    """Re-simulate ``bag`` and compare it with its recorded joint states.

    Returns {bag, status, states, max_angle, max_velocity, worst, seconds, error}: the largest
    |Δθ| [rad] and |Δω| [rad/s] over joints, ``worst`` the larger of both, ``seconds`` the
    wall time of the job, ``error`` the reason of status 'error' (else '').
    """
    from affine_joint_sim.ros.replay import ReplayError, read_bag, replay
    from affine_joint_sim.scene import SceneError

    start = time.perf_counter()
    result = failed_result(bag, '')
    try:
        divergence = replay(read_bag(bag), scene, device)
    except (ReplayError, SceneError, OSError) as exc:
        result['error'] = str(exc).splitlines()[0]
    except Exception as exc:           # anything else is reported with the bag, not raised
        result['error'] = f'{type(exc).__name__}: {exc}'.splitlines()[0]
    else:
        worst = divergence.worst()
        result.update(status='pass' if worst <= tol else 'fail', states=divergence.states,
                      max_angle=float(divergence.max_angle.max(initial=0.0)),
                      max_velocity=float(divergence.max_velocity.max(initial=0.0)),
                      worst=worst)
    result['seconds'] = time.perf_counter() - start
    return result
