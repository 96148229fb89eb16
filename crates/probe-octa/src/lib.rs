//! `probe_octa`: work in progress; see the workspace README.
