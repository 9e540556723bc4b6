//! Weighted least-squares fits with uncertainties, and the fit forms the papers use.
