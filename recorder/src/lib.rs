//! MCAP writer, the deterministic stage runner and the live runtime.
