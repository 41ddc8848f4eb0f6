//! What the navigation firmwares share (`imu-ident-nav-qemu`, `imu-ident-nav-board`): the
//! online identification's bank in the core-coupled memory and its start, the telemetry of an
//! epoch, of the solution at the newest sample and of a decision. Wiring only; the navigator
//! and the bank are the library's.

use core::mem::MaybeUninit;
use core::sync::atomic::{AtomicBool, Ordering};

use imu_ident::nav::predictor::Present;
use imu_ident::nav::{Epoch, NavError, NavReplay, NavSd, NavSetup, OnlineIdent, NAV_N};

/// Shadow filters of the online identification (the core's count for the firmware).
const BANK: usize = imu_ident::nav::online::FIRMWARE_BANK;

/// The counter of a sensor hub that stamps its samples with counts instead of GPS time
/// (`imu_ident::nav::counted`: counted samples and pulse edges) [Hz]: an 84-MHz timer (an
/// STM32's APB1 timers at 168 MHz). Set it to the hub's; a wire of GPS-stamped samples never
/// uses it.
pub const HUB_TIMER_HZ: f64 = 84e6;

/// The online identification's bank.
pub type Bank = OnlineIdent<f32, NAV_N, BANK>;

/// The navigation run, with the bank when the setup asks for it.
pub type Run = NavReplay<f32, NAV_N, Option<&'static mut Bank>>;

/// The online identification's bank (about 59 KB), in the core-coupled memory
/// (`memory/ccmram.x`: the F405's 128 KiB SRAM holds the other statics and the stack).
/// That section is not zeroed at reset: [`start_bank`] writes it before any read.
#[link_section = ".ccmram.bank"]
static mut BANK_STATE: MaybeUninit<Bank> = MaybeUninit::uninit();
/// Set when [`BANK_STATE`] has been handed out.
static BANK_TAKEN: AtomicBool = AtomicBool::new(false);

/// Starts the online identification's bank in [`BANK_STATE`] when the setup asks for it
/// (its own frame: the shadows' construction is not part of the caller's). Called when the run
/// is built (a replay) or placed (the live loop); a second call gets no bank.
#[inline(never)]
pub fn start_bank(
    setup: &NavSetup,
    plain: &NavReplay<f32, NAV_N>,
) -> Result<Option<&'static mut Bank>, NavError> {
    let Some(cfg) = setup.online else {
        return Ok(None);
    };
    if BANK_TAKEN.swap(true, Ordering::AcqRel) {
        return Ok(None);
    }
    // SAFETY: BANK_TAKEN was false, so this is the only reference to BANK_STATE ever made.
    let slot = unsafe { &mut *core::ptr::addr_of_mut!(BANK_STATE) };
    let bank = slot.write(Bank::BLANK);
    bank.start(cfg, plain.navigator(), setup.t0)
        .map_err(NavError::Model)?;
    Ok(Some(bank))
}

/// Decisions the online identification's bank has taken (0 without a bank).
pub fn decisions_of(run: &Run) -> u32 {
    run.navigator()
        .observer()
        .as_deref()
        .map_or(0, |b| b.decisions())
}

/// Telemetry of a decision: per coordinate its log10 factor on the starting model, its
/// Cramér-Rao sd [decades] and the flag "identifiable from these data" (sd at most
/// `IDENTIFIABLE_SD`; issue 13's flag, sent rather than letting a flat coordinate wander).
pub fn report_decision(run: &Run, t: f64) {
    let Some(bank) = run.navigator().observer().as_deref() else {
        return;
    };
    for (i, (x, sd)) in bank.log10_factors().iter().zip(bank.cr_sd()).enumerate() {
        defmt::info!(
            "online t={=f64} i={=u8} x={=f64} sd={=f64} ok={=bool}",
            t,
            i as u8,
            *x,
            *sd,
            bank.identifiable(i)
        );
    }
}

/// The solution at a GNSS epoch, as telemetry.
pub fn send_epoch(e: &Epoch<f32>) {
    let [vn, ve, vd] = e.vel;
    let [sn, se, sd] = e.sd_pos;
    defmt::info!(
        "nav t={=f64} lat={=f64} lon={=f64} h={=f64} vn={=f32} ve={=f32} vd={=f32} sdn={=f32} sde={=f32} sdd={=f32} flags={=u8}",
        e.t, e.pos.lat, e.pos.lon, e.pos.h, vn, ve, vd, sn, se, sd, e.flags
    );
}

/// The solution at the newest sample is sent every this many IMU samples (10 Hz at 100 Hz).
const PRESENT_EVERY: u32 = 10;

/// The solution at the newest sample and its standard deviations (`LiveNav::present`,
/// `LiveNav::present_sd`).
pub type PresentWithSd<'a> = (Present<'a, f32>, Option<NavSd<f32>>);

/// Counts an IMU sample given to the live loop in `samples` and, every [`PRESENT_EVERY`]-th,
/// sends the solution at the newest sample when there is one (`present`, asked only then).
pub fn count_sample<'a>(samples: &mut u32, present: impl FnOnce() -> Option<PresentWithSd<'a>>) {
    *samples = samples.wrapping_add(1);
    if *samples % PRESENT_EVERY == 0 {
        if let Some((now, sd)) = present() {
            send_present(&now, sd.as_ref());
        }
    }
}

/// The solution at the newest sample (the output predictor's, `imu_ident::nav::predictor`),
/// as telemetry: time, position, NED velocity, roll, pitch, yaw [rad], and the standard
/// deviations of the attitude [rad], velocity [m/s] and position [m] errors, N, E, D each
/// (NaN when there are none).
fn send_present(now: &Present<'_, f32>, sd: Option<&NavSd<f32>>) {
    let ins = now.ins();
    let (p, v) = (ins.position(), ins.velocity());
    let (roll, pitch, yaw) = ins.attitude_f64().euler();
    let none = [f32::NAN; 3];
    let (sa, sv, sp) = sd.map_or((none, none, none), |s| (s.att, s.vel, s.pos));
    defmt::info!(
        "now t={=f64} lat={=f64} lon={=f64} h={=f64} vn={=f32} ve={=f32} vd={=f32} roll={=f32} pitch={=f32} yaw={=f32} san={=f32} sae={=f32} sad={=f32} svn={=f32} sve={=f32} svd={=f32} spn={=f32} spe={=f32} spd={=f32}",
        now.time(),
        p.lat,
        p.lon,
        p.h,
        v.x,
        v.y,
        v.z,
        roll as f32,
        pitch as f32,
        yaw as f32,
        sa[0],
        sa[1],
        sa[2],
        sv[0],
        sv[1],
        sv[2],
        sp[0],
        sp[1],
        sp[2]
    );
}
