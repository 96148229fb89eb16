//! `probe_index`: work in progress; see the workspace README.
