//! anybox results JSON and the BOP19 CSV.
