//! Rerun sink over the rodlog message stream: draws messages, never computes robot logic.
