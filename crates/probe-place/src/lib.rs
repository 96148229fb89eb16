//! `probe_place`: work in progress; see the workspace README.
