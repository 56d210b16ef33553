//! MCAP reader (time order, filters, recovery of truncated files), replay, divergence check, what-if.
