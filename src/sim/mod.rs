//! Event-driven molecular dynamics of 2D hard disks (paper H, Sec. 2; paper I).
