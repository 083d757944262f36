//! The records' route: an opened file's records in their resident form (`resident.rs`), where a
//! query falls among the stored incidences (`lattice.rs`, `incidence.rs`), how the records it
//! blends combine (`blend.rs`), and the general path that evaluates them for any lattice and
//! lobe kind (`general.rs`), with its dot products in a fixed order (`dot.rs`).

pub(crate) mod blend;
pub(crate) mod dot;
pub(crate) mod general;
pub(crate) mod incidence;
pub(crate) mod lattice;
pub(crate) mod resident;
