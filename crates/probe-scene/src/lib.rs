//! `probe_scene`: work in progress; see the workspace README.
