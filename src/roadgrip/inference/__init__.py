"""Generic inference building blocks shared by the estimators.

* :mod:`roadgrip.inference.kalman`: Cholesky, sigma points, unscented transform and
  the Joseph-form update, compiled.
* :mod:`roadgrip.inference.rls`: recursive least squares with forgetting and the
  bistable RLS of paper 002.
* :mod:`roadgrip.inference.basis`: reduced-rank Gaussian-process basis (Hilbert space
  eigenfunctions) of paper 000.
* :mod:`roadgrip.inference.kinematic`: the kinematic velocity observer (body velocity
  and wheel slips from wheel speeds, IMU and pose).
"""
