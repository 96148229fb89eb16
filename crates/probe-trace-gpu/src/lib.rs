//! `probe_trace_gpu`: work in progress; see the workspace README.
