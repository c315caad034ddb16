"""Identification: inverse dynamic identification by least squares (IDIM-LS), the parametric SDP stage."""
