//! Figure drawing with plotters (SVG and PNG, embedded font).
