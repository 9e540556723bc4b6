//! Observables computed from stored trajectories (overlap, chi4, S4, MSD, clusters, ...).
