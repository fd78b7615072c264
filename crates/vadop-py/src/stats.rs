//! Statistics of a frame as Python sees them: the core's `FrameStats` as a dict of the same names
//! (seconds per stage, counters, the contacts a rule changed, the collisional virial). It owns
//! that translation only.

use pyo3::prelude::*;
use pyo3::types::PyDict;
use vadop::FrameStats;

/// The dict `World.stats()` returns for the frame stats `s`.
pub(crate) fn frame_stats<'py>(py: Python<'py>, s: &FrameStats) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("update_seconds", s.update_seconds)?;
    d.set_item("sort_seconds", s.sort_seconds)?;
    d.set_item("test_seconds", s.test_seconds)?;
    d.set_item("response_seconds", s.response_seconds)?;
    d.set_item("total_seconds", s.total_seconds())?;
    d.set_item("windows", s.windows)?;
    d.set_item("endpoint_swaps", s.endpoint_swaps)?;
    d.set_item("list_entries", s.list_entries)?;
    d.set_item("candidate_pairs", s.candidate_pairs)?;
    d.set_item("narrow_tests", s.narrow_tests)?;
    d.set_item("retests", s.retests)?;
    d.set_item("contacts", s.contacts)?;
    d.set_item("pair_contacts", s.pair_contacts)?;
    d.set_item("invalidations", s.invalidations)?;
    d.set_item("broad_phase_bytes", s.broad_phase_bytes)?;
    d.set_item("tc_contacts", s.tc_contacts)?;
    d.set_item("jam_contacts", s.jam_contacts)?;
    d.set_item("rest_contacts", s.rest_contacts)?;
    d.set_item("pair_virial", s.pair_virial)?;
    Ok(d)
}
