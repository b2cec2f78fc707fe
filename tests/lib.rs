//! Workspace-level integration tests live in `tests/tests/`: they exercise
//! the crates together (simulator → navlog → navigator → evaluator).
