"""Shared test helpers."""

import os
import pathlib

import pytest

SHARED = pathlib.Path(
    os.environ.get("JAXSDP_SHARED", pathlib.Path(__file__).resolve().parents[1] / ".." / "shared")
).resolve()
EMPS_MAT = SHARED / "data" / "emps" / "DATA_EMPS.mat"
EMPS_DEC10_CSV = SHARED / "reference" / "emps_inputs_dec10.csv"

requires_emps = pytest.mark.skipif(
    not EMPS_MAT.exists(),
    reason=f"EMPS benchmark data not found at {EMPS_MAT} (set JAXSDP_SHARED to the shared/ folder)",
)
requires_emps_csv = pytest.mark.skipif(
    not EMPS_DEC10_CSV.exists(),
    reason=f"reference EMPS inputs not found at {EMPS_DEC10_CSV} (set JAXSDP_SHARED to the shared/ folder)",
)
TX40_DIR = SHARED / "data" / "tx40"
TX40_POSITIONS = TX40_DIR / "pos_read_data.csv"
TX40_CURRENTS = TX40_DIR / "curr_data.csv"

requires_tx40 = pytest.mark.skipif(
    not (TX40_POSITIONS.exists() and TX40_CURRENTS.exists()),
    reason=f"real TX40 joint logs not found in {TX40_DIR} (set JAXSDP_SHARED to the shared/ folder)",
)
