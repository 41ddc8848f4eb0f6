//! hal-sim: the host test bed of imu-ident. It drives the same no_std core on x86.
