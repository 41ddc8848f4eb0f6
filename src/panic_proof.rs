//! The link-time proof that no panic path survives optimisation (feature `prove-no-panic`,
//! bare-metal release builds only; RELIABILITY.md, "Panic-free firmware, proved at link time").
//!
//! With the feature, this is the program's `#[panic_handler]` (each firmware binary defines its
//! own only without it): it calls `imu_ident_panic_path_is_linked`, an `extern "Rust"`
//! function defined nowhere, so a binary links only if every call to the handler was optimised
//! away, and otherwise fails naming that symbol.

extern "Rust" {
    /// Defined nowhere (see the module documentation).
    fn imu_ident_panic_path_is_linked() -> !;
}

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo) -> ! {
    // SAFETY: never executed; the symbol does not exist, so a binary that could reach this call
    // does not link.
    unsafe { imu_ident_panic_path_is_linked() }
}
