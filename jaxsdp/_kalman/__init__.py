"""Estimation core: Kalman filter and RTS smoother kernels, parameter models, dynamic linear regression, ML NVRs."""
