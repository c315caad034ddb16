"""Estimation core: state-dependent parameter (SDP) back-fitting, multi-SDP, CAPTAIN-style NVR search."""
