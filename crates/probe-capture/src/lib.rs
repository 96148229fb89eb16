//! `probe_capture`: work in progress; see the workspace README.
