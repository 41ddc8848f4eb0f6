//! The strapdown INS/GNSS formats (README "Strapdown INS/GNSS formats") on synthetic files:
//! round trips, columns by name in any order, errors naming file, line and column, RTKLIB
//! `.pos` read and written with RTKLIB's header, the GPST time scale, the IMU-to-body rotation,
//! the outage schedule and the outage score against known answers.

use hal_sim::nav_io::drive::imu_to_body;
use hal_sim::nav_io::gnss_csv::read_gnss_csv_from;
use hal_sim::nav_io::imu_csv::read_imu_csv_from;
use hal_sim::nav_io::outages::{north_east, withheld, Outage};
use hal_sim::nav_io::rtklib_pos::{parse_pos, TimeFormat};
use hal_sim::nav_io::truth_csv::read_truth_csv_from;
use hal_sim::nav_io::{gpst, *};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn err<T: std::fmt::Debug>(r: anyhow::Result<T>) -> String {
    format!("{:#}", r.expect_err("expected an error"))
}

#[test]
fn imu_csv_round_trips_exactly_and_finds_columns_by_name() {
    let mut rng = ChaCha8Rng::seed_from_u64(16);
    let samples: Vec<ImuSample> = (0..200)
        .map(|k| ImuSample {
            t: 1.436e9 + 0.01 * k as f64 + rng.gen_range(0.0..1e-3),
            gyro: std::array::from_fn(|_| rng.gen_range(-3.0..3.0)),
            accel: std::array::from_fn(|_| rng.gen_range(-30.0..30.0)),
        })
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("imu.csv");
    write_imu_csv(&p, &samples).unwrap();
    let text = std::fs::read_to_string(&p).unwrap();
    assert!(text.starts_with("t,gx,gy,gz,ax,ay,az\n"));
    assert_eq!(read_imu_csv(&p).unwrap(), samples);

    // Any order, extra columns ignored, blanks trimmed.
    let csv =
        "az, extra ,ax,t,gz,gy,gx,ay\n-9.8,x,0.1,5.0,0.03,0.02,0.01,0.2\n-9.7,y,0.1,5.01,0,0,0,0\n";
    let s = read_imu_csv_from(csv.as_bytes(), "mem.csv").unwrap();
    assert_eq!(s.len(), 2);
    assert_eq!(s[0].t, 5.0);
    assert_eq!(s[0].gyro, [0.01, 0.02, 0.03]);
    assert_eq!(s[0].accel, [0.1, 0.2, -9.8]);
}

#[test]
fn imu_csv_errors_name_file_line_and_column() {
    let e = err(read_imu_csv_from(
        "t,gx,gy,ax,ay,az\n0,0,0,0,0,0\n".as_bytes(),
        "a.csv",
    ));
    assert!(e.contains("a.csv line 1") && e.contains("'gz'"), "{e}");
    let e = err(read_imu_csv_from(
        "t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,0\n1,0,0,0,0,abc,0\n".as_bytes(),
        "b.csv",
    ));
    assert!(
        e.contains("b.csv line 3, column ay") && e.contains("abc"),
        "{e}"
    );
    let e = err(read_imu_csv_from(
        "t,gx,gy,gz,ax,ay,az\n0,0,0,,0,0,0\n".as_bytes(),
        "c.csv",
    ));
    assert!(
        e.contains("c.csv line 2, column gz") && e.contains("empty"),
        "{e}"
    );
    let e = err(read_imu_csv_from(
        "t,gx,gy,gz,ax,ay,az\n1,0,0,0,0,0,0\n1,0,0,0,0,0,0\n".as_bytes(),
        "d.csv",
    ));
    assert!(
        e.contains("d.csv line 3, column t") && e.contains("does not increase"),
        "{e}"
    );
    let e = err(read_imu_csv_from(
        "t,gx,gy,gz,ax,ay,az\n0,0,0,0,inf,0,0\n".as_bytes(),
        "e.csv",
    ));
    assert!(
        e.contains("e.csv line 2, column ax") && e.contains("finite"),
        "{e}"
    );
}

#[test]
fn gnss_csv_optional_groups_and_round_trip() {
    let fixes = vec![
        GnssFix {
            t: 10.0,
            lat_deg: 40.1,
            lon_deg: -105.1,
            h: 1600.5,
            vel_ned: Some([1.0, -2.0, 0.1]),
            sd_pos_ned: Some([0.01, 0.02, 0.03]),
            sd_vel_ned: Some([0.05, 0.05, 0.06]),
        },
        GnssFix {
            t: 10.25,
            lat_deg: 40.100001,
            lon_deg: -105.100002,
            h: 1600.25,
            vel_ned: None,
            sd_pos_ned: Some([0.5, 0.5, 1.0]),
            sd_vel_ned: None,
        },
    ];
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("gnss.csv");
    write_gnss_csv(&p, &fixes).unwrap();
    assert_eq!(read_gnss_csv(&p).unwrap(), fixes);

    // Only the required columns.
    let g = read_gnss_csv_from("h,lon,lat,t\n5,2,1,0\n".as_bytes(), "m.csv").unwrap();
    assert_eq!(
        g[0],
        GnssFix {
            t: 0.0,
            lat_deg: 1.0,
            lon_deg: 2.0,
            h: 5.0,
            ..Default::default()
        }
    );
    // A group is all or nothing; NaN is "no value".
    let e = err(read_gnss_csv_from(
        "t,lat,lon,h,vn,ve,vd\n0,1,2,3,0.1,,0.3\n".as_bytes(),
        "g.csv",
    ));
    assert!(
        e.contains("g.csv line 2, column ve") && e.contains("vn,ve,vd"),
        "{e}"
    );
    let g = read_gnss_csv_from("t,lat,lon,h,vn,ve,vd\n0,1,2,3,NaN,nan,\n".as_bytes(), "n").unwrap();
    assert_eq!(g[0].vel_ned, None);
    let e = err(read_gnss_csv_from(
        "t,lat,lon,h,sd_n,sd_e,sd_d\n0,1,2,3,0.1,-0.1,0.1\n".as_bytes(),
        "s.csv",
    ));
    assert!(
        e.contains("s.csv line 2, column sd_e") && e.contains("negative"),
        "{e}"
    );
    let e = err(read_gnss_csv_from(
        "t,lat,lon,h\n0,95,2,3\n".as_bytes(),
        "l.csv",
    ));
    assert!(e.contains("l.csv line 2, column lat"), "{e}");
}

#[test]
fn truth_csv_round_trips_with_and_without_biases() {
    let rows = vec![
        TruthRow {
            t: 0.0,
            lat_deg: 45.0,
            lon_deg: 7.5,
            h: 300.0,
            vel_ned: [10.0, 0.5, -0.1],
            rpy_deg: [1.0, -2.0, 179.5],
            gyro_bias: Some([1e-5, -2e-5, 3e-5]),
            accel_bias: Some([0.01, -0.02, 0.03]),
        },
        TruthRow {
            t: 0.01,
            gyro_bias: None,
            accel_bias: None,
            ..Default::default()
        },
    ];
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("truth.csv");
    write_truth_csv(&p, &rows).unwrap();
    let text = std::fs::read_to_string(&p).unwrap();
    assert!(text.starts_with("t,lat,lon,h,vn,ve,vd,roll,pitch,yaw,bg_x,bg_y,bg_z,ba_x,ba_y,ba_z\n"));
    assert_eq!(read_truth_csv(&p).unwrap(), rows);
    let e = err(read_truth_csv_from(
        "t,lat,lon,h,vn,ve,vd,roll,pitch\n".as_bytes(),
        "t.csv",
    ));
    assert!(e.contains("t.csv line 1") && e.contains("'yaw'"), "{e}");
}

#[test]
fn gpst_scale_is_seconds_since_1980_01_06() {
    assert_eq!(gpst::parse_calendar("1980/01/06", "00:00:00"), Some(0.0));
    assert_eq!(
        gpst::parse_calendar("1980/01/13", "00:00:00.000"),
        Some(gpst::WEEK)
    );
    assert_eq!(
        gpst::parse_calendar("80/01/13", "00:00:01"),
        Some(gpst::WEEK + 1.0)
    );
    // Unix 315964800 is 1980-01-06 on a clock without leap seconds.
    assert_eq!(gpst::from_unix_label(315_964_800, 0.25), 0.25);
    let t = gpst::parse_calendar("2025/07/08", "19:34:18.499").unwrap();
    assert_eq!(gpst::to_calendar(t).unwrap(), "2025/07/08 19:34:18.499");
    let week = (t / gpst::WEEK).floor();
    assert_eq!(
        gpst::from_week_seconds(week as u32, t - week * gpst::WEEK),
        t
    );
    // Rounding to the millisecond carries into the minute, as RTKLIB's time2str does.
    let t = gpst::parse_calendar("2025/07/08", "19:34:59.9996").unwrap();
    assert_eq!(gpst::to_calendar(t).unwrap(), "2025/07/08 19:35:00.000");
    assert_eq!(gpst::to_calendar(f64::NAN), None);
    assert_eq!(gpst::parse_calendar("2025/13/08", "19:34:18"), None);
}

fn epochs(n: usize, vel: bool) -> Vec<PosEpoch> {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let t0 = gpst::parse_calendar("2025/07/08", "19:34:18.499").unwrap();
    (0..n)
        .map(|k| PosEpoch {
            fix: GnssFix {
                t: t0 + 0.25 * k as f64,
                lat_deg: 40.0966268 + rng.gen_range(-1e-3..1e-3),
                lon_deg: -105.1474483 + rng.gen_range(-1e-3..1e-3),
                h: 1601.474 + rng.gen_range(-5.0..5.0),
                vel_ned: vel.then(|| std::array::from_fn(|_| rng.gen_range(-20.0..20.0))),
                sd_pos_ned: Some(std::array::from_fn(|_| rng.gen_range(0.0..2.0))),
                sd_vel_ned: vel.then(|| std::array::from_fn(|_| rng.gen_range(0.0..0.5))),
            },
            q: [1, 2, 5, 7][k % 4],
            ns: (k % 30) as u16,
            sd_cross: std::array::from_fn(|_| rng.gen_range(-0.5..0.5)),
            age: rng.gen_range(0.0..10.0),
            ratio: rng.gen_range(0.0..999.0),
            sd_vel_cross: if vel {
                std::array::from_fn(|_| rng.gen_range(-0.1..0.1))
            } else {
                [0.0; 3]
            },
        })
        .collect()
}

/// Equal to the precision RTKLIB prints (half a unit of the last printed digit).
fn assert_close(a: &PosEpoch, b: &PosEpoch) {
    let near = |x: f64, y: f64, dec: i32| {
        assert!(
            (x - y).abs() <= 0.5 * 10f64.powi(-dec) * 1.000001,
            "{x} vs {y} ({dec} decimals)"
        )
    };
    let (f, g) = (&a.fix, &b.fix);
    near(f.t, g.t, 3);
    near(f.lat_deg, g.lat_deg, 9);
    near(f.lon_deg, g.lon_deg, 9);
    near(f.h, g.h, 4);
    assert_eq!((a.q, a.ns), (b.q, b.ns));
    for k in 0..3 {
        near(f.sd_pos_ned.unwrap()[k], g.sd_pos_ned.unwrap()[k], 4);
        near(a.sd_cross[k], b.sd_cross[k], 4);
    }
    near(a.age, b.age, 2);
    near(a.ratio, b.ratio, 1);
    assert_eq!(f.vel_ned.is_some(), g.vel_ned.is_some());
    if let (Some(v), Some(w)) = (f.vel_ned, g.vel_ned) {
        for k in 0..3 {
            near(v[k], w[k], 5);
            near(f.sd_vel_ned.unwrap()[k], g.sd_vel_ned.unwrap()[k], 5);
            near(a.sd_vel_cross[k], b.sd_vel_cross[k], 5);
        }
    }
}

#[test]
fn solution_pos_round_trips_to_the_printed_precision_with_rtklib_header() {
    let dir = tempfile::tempdir().unwrap();
    for vel in [false, true] {
        let e = epochs(50, vel);
        let p = dir.path().join(format!("solution-{vel}.pos"));
        write_solution_pos(&p, &e, "hal-sim nav").unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        // The column header exactly as RTKLIB's outsolheads prints it (GPST, llh in degrees,
        // three decimals of seconds).
        let head = text.lines().find(|l| l.contains("latitude(deg)")).unwrap();
        let want = "%  GPST                  latitude(deg) longitude(deg)  height(m)   Q  ns   sdn(m)   sde(m)   sdu(m)  sdne(m)  sdeu(m)  sdun(m) age(s)  ratio";
        assert!(head.starts_with(want), "{head}");
        assert_eq!(head.contains("vn(m/s)"), vel);
        let back = read_pos(&p).unwrap();
        assert_eq!(back.time_format, Some(TimeFormat::Calendar));
        assert_eq!(back.epochs.len(), e.len());
        for (a, b) in e.iter().zip(&back.epochs) {
            assert_close(a, b);
        }
        // Q filter: 1 <= Q <= max_q.
        assert_eq!(back.fixes(1).len(), e.iter().filter(|x| x.q == 1).count());
        assert_eq!(back.fixes(2).len(), e.iter().filter(|x| x.q <= 2).count());
    }
}

#[test]
fn pos_reader_accepts_week_seconds_and_up_velocity_becomes_down() {
    let t = gpst::parse_calendar("2025/07/08", "19:34:18.499").unwrap();
    let week = (t / gpst::WEEK).floor();
    let sow = t - week * gpst::WEEK;
    let text = format!(
        "% program   : x\n%  GPST          latitude(deg) longitude(deg)  height(m)   Q  ns   sdn(m)   sde(m)   sdu(m)  sdne(m)  sdeu(m)  sdun(m) age(s)  ratio    vn(m/s)    ve(m/s)    vu(m/s)      sdvn     sdve     sdvu    sdvne    sdveu    sdvun\n{week:.0} {sow:.3}   40.096626800 -105.147448300  1601.4740   1  21   0.0099   0.0099   0.0100   0.0000   0.0000   0.0000   0.00    0.0    1.00000   -2.00000    0.50000   0.05869  0.05869  0.05869  0.00000  0.00000  0.00000\n"
    );
    let p = parse_pos(&text, "w.pos").unwrap();
    assert_eq!(p.time_format, Some(TimeFormat::WeekSeconds));
    let f = p.epochs[0].fix;
    assert!((f.t - t).abs() < 1e-6);
    assert_eq!(f.vel_ned, Some([1.0, -2.0, -0.5]));
    assert_eq!(f.sd_vel_ned, Some([0.05869; 3]));
    // Comma-separated, as RTKLIB writes with out-fieldsep=",".
    let text = "%  GPST,latitude(deg),longitude(deg),height(m),Q,ns\n2025/07/08 19:34:18.499,40.1,-105.1,1601.5,1,21\n";
    let p = parse_pos(text, "c.pos").unwrap();
    assert_eq!((p.epochs[0].fix.lat_deg, p.epochs[0].q), (40.1, 1));
}

#[test]
fn pos_reader_refuses_what_it_cannot_read_and_names_the_field() {
    let e = err(parse_pos("%  GPST   x-ecef(m)   y-ecef(m)\n", "x.pos"));
    assert!(e.contains("x.pos line 1") && e.contains("ECEF"), "{e}");
    let e = err(parse_pos(
        "%  UTC   latitude(deg) longitude(deg)\n",
        "u.pos",
    ));
    assert!(e.contains("u.pos line 1") && e.contains("GPST"), "{e}");
    let e = err(parse_pos(
        "% h\n2025/07/08 19:34:18.499 40.1 -105.1 1601.5 1 21 0.01 zz 0.01\n",
        "f.pos",
    ));
    assert!(
        e.contains("f.pos line 2, field sde") && e.contains("zz"),
        "{e}"
    );
    let e = err(parse_pos(
        "2025/07/08 19:34:18.499 40.1 -105.1 1601.5 1.5 21\n",
        "q.pos",
    ));
    assert!(e.contains("q.pos line 1, field Q"), "{e}");
    let e = err(parse_pos("2025/07/08 19:34:18.499 40.1 -105.1\n", "n.pos"));
    assert!(e.contains("n.pos line 1") && e.contains("Q ns"), "{e}");
    let e = err(parse_pos(
        "2025/07/08 19:34:18.499 40.1 -105.1 1 1 1\n2025/07/08 19:34:18.499 40.1 -105.1 1 1 1\n",
        "d.pos",
    ));
    assert!(
        e.contains("d.pos line 2") && e.contains("does not increase"),
        "{e}"
    );
    let e = err(parse_pos(
        "2025/07/32 19:34:18.499 40.1 -105.1 1 1 1\n",
        "t.pos",
    ));
    assert!(e.contains("t.pos line 1, field time"), "{e}");
}

/// Groves' Euler_to_CTM (eq. 2.22) written out element by element, to check the nalgebra form.
fn groves_ctm([phi, theta, psi]: [f64; 3]) -> [[f64; 3]; 3] {
    let (sp, cp) = phi.sin_cos();
    let (st, ct) = theta.sin_cos();
    let (ss, cs) = psi.sin_cos();
    [
        [ct * cs, ct * ss, -st],
        [-cp * ss + sp * st * cs, cp * cs + sp * st * ss, sp * ct],
        [sp * ss + cp * st * cs, -sp * cs + cp * st * ss, cp * ct],
    ]
}

#[test]
fn imu_to_body_is_groves_euler_to_ctm() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for _ in 0..100 {
        let a: [f64; 3] = std::array::from_fn(|_| rng.gen_range(-3.2..3.2));
        let c = imu_to_body(a);
        let g = groves_ctm(a);
        for i in 0..3 {
            for j in 0..3 {
                assert!((c[(i, j)] - g[i][j]).abs() < 1e-14);
            }
        }
    }
    // The mounting alone: x backwards, y unchanged, z up.
    let c = imu_to_body([180f64.to_radians(), 0.0, 180f64.to_radians()]);
    let d = [-1.0, 1.0, -1.0];
    for i in 0..3 {
        for j in 0..3 {
            let want = if i == j { d[i] } else { 0.0 };
            assert!((c[(i, j)] - want).abs() < 1e-15);
        }
    }
}

#[test]
fn outage_schedule_and_withholding() {
    let s: OutageSpec = "40,15,45,30".parse().unwrap();
    // 549 s of GNSS: starts 40 + 45 k < 519, k = 0..10.
    let o = s.schedule(1000.0, 1549.0);
    assert_eq!(o.len(), 11);
    assert_eq!((o[0].start, o[0].end), (1040.0, 1055.0));
    assert_eq!(o[10].start, 1490.0);
    // A start exactly at last - margin is not taken.
    assert_eq!(s.schedule(0.0, 30.0 + 40.0 + 45.0).len(), 1);
    assert_eq!(s.schedule(0.0, 30.0 + 40.0 + 45.0 + 1e-9).len(), 2);
    assert!(s.schedule(0.0, 60.0).is_empty());
    assert!(withheld(&o, 1040.0) && withheld(&o, 1054.999));
    assert!(!withheld(&o, 1055.0) && !withheld(&o, 1039.99) && !withheld(&o, 2000.0));
    for bad in [
        "40,15,45",
        "40,15,10,30",
        "40,0,45,30",
        "a,15,45,30",
        "40,15,45,-1",
    ] {
        assert!(bad.parse::<OutageSpec>().is_err(), "{bad}");
    }
}

#[test]
fn north_east_matches_the_known_arc_lengths() {
    // One arc-second at the equator: 30.715 m along the meridian (radius a(1-e2)),
    // 30.922 m along the equator (radius a).
    let s = 1.0 / 3600.0;
    let [n, e] = north_east(0.0, 0.0, 0.0, s, s);
    assert!((n - 30.7155).abs() < 1e-3, "{n}");
    assert!((e - 30.9221).abs() < 1e-3, "{e}");
    // Longitude wraps at the antimeridian.
    let [_, e] = north_east(0.0, 179.9999, 0.0, 0.0, -179.9999);
    assert!((e - 0.0002 * 111_319.49).abs() < 0.01, "{e}");
}

#[test]
fn outage_score_has_the_known_answer() {
    // Reference: 4 Hz RTK epochs moving north. Solution: 1 Hz, offset from the reference by
    // 3 m north and c t metres east (linear in time, so interpolation is exact): the error at
    // the last reference epoch t_k before the end of outage k is hypot(3, c t_k).
    let (lat0, lon0, h) = (40.0, -105.0, 1600.0);
    // Metres per degree at latitude `lat`, from the function under test's own radii (checked
    // against known arc lengths above); the offsets are built at each epoch's latitude.
    let m_per_deg = |lat: f64| {
        let n = north_east(lat, lon0, h, lat + 1e-6, lon0)[0] / 1e-6;
        let e = north_east(lat, lon0, h, lat, lon0 + 1e-6)[1] / 1e-6;
        (n, e)
    };
    let m_per_deg_n = m_per_deg(lat0).0;
    let lat_at = |t: f64| lat0 + 10.0 * t / m_per_deg_n;
    let reference: Vec<GnssFix> = (0..=2000)
        .map(|k| {
            let t = 0.25 * k as f64;
            GnssFix {
                t,
                lat_deg: lat_at(t),
                lon_deg: lon0,
                h,
                ..Default::default()
            }
        })
        .collect();
    let c = 0.02;
    let track: Vec<(f64, f64, f64)> = (0..501)
        .map(|k| {
            let t = k as f64 + 0.1;
            let (n, e) = m_per_deg(lat_at(t));
            (t, lat_at(t) + 3.0 / n, lon0 + c * t / e)
        })
        .collect();
    let outages = OutageSpec {
        start: 40.0,
        len: 15.0,
        period: 45.0,
        margin: 30.0,
    }
    .schedule(0.0, 500.0);
    let s = score_outages(&track, &reference, &outages);
    assert_eq!((s.outages.len(), s.unscored), (outages.len(), 0));
    let want: Vec<f64> = outages
        .iter()
        .map(|o| 3.0f64.hypot(c * (o.end - 0.25)))
        .collect();
    for (sc, w) in s.outages.iter().zip(&want) {
        assert_eq!(sc.t, sc.outage.end - 0.25);
        // Linearisation over a few metres and over 1 s of interpolation: ~1e-6 relative.
        assert!((sc.err_h - w).abs() < 1e-5, "{} vs {w}", sc.err_h);
    }
    let rms = (want.iter().map(|x| x * x).sum::<f64>() / want.len() as f64).sqrt();
    let mut sorted = want.clone();
    sorted.sort_by(f64::total_cmp);
    assert!((s.rms - rms).abs() < 1e-5);
    let m = sorted.len() / 2;
    // 10 outages: the median is the mean of the two middle ones.
    assert_eq!(sorted.len(), 10);
    assert!((s.median - 0.5 * (sorted[m - 1] + sorted[m])).abs() < 1e-5);
    assert!((s.max - sorted[sorted.len() - 1]).abs() < 1e-5);

    // An outage with no reference epoch inside it, or beyond the track, is not scored.
    let gap = [Outage {
        start: 600.0,
        end: 610.0,
    }];
    assert_eq!(score_outages(&track, &reference, &gap).unscored, 1);
    let late = [Outage {
        start: 10.0,
        end: 10.2,
    }];
    assert_eq!(score_outages(&track, &reference[..1], &late).unscored, 1);
}

#[test]
fn zero_period_spec_gives_one_outage_not_endless_ones() {
    let s = OutageSpec {
        start: 1.0,
        len: 1.0,
        period: 0.0,
        margin: 0.0,
    };
    assert_eq!(s.schedule(0.0, 100.0).len(), 1);
}

mod fuzz {
    //! The new parsers on arbitrary text: rows or an error naming the file, never a panic.
    //! 512 cases per test (fixed by proptest's deterministic runner).
    use super::*;
    use proptest::prelude::*;

    /// Lines built from the tokens these formats use, so that parsing gets past the first field.
    fn pos_text() -> impl Strategy<Value = String> {
        let token = prop_oneof![
            Just("2025/07/08".to_string()),
            Just("19:34:18.499".to_string()),
            Just("2374".to_string()),
            Just("243258.5".to_string()),
            Just("%  GPST latitude(deg) longitude(deg)".to_string()),
            Just("% x-ecef(m)".to_string()),
            Just("NaN".to_string()),
            Just("1e308".to_string()),
            Just("-".to_string()),
            any::<f64>().prop_map(|x| x.to_string()),
            any::<i32>().prop_map(|x| x.to_string()),
            "[ -~]{0,12}",
        ];
        proptest::collection::vec(proptest::collection::vec(token, 0..26), 0..6).prop_map(|lines| {
            lines
                .into_iter()
                .map(|l| l.join(" "))
                .collect::<Vec<_>>()
                .join("\n")
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 512, failure_persistence: None, ..ProptestConfig::default() })]

        #[test]
        fn pos_parser_never_panics(text in pos_text()) {
            if let Err(e) = parse_pos(&text, "fuzz.pos") {
                let msg = format!("{:#}", e);
                prop_assert!(msg.contains("fuzz.pos"), "{}", msg);
            }
        }

        #[test]
        fn csv_readers_never_panic(body in "[-0-9a-z.,;\\n ]{0,200}", head in 0usize..3) {
            let header = ["t,gx,gy,gz,ax,ay,az", "t,lat,lon,h,vn,ve,vd,sd_n", "t,lat,lon,h,vn,ve,vd,roll,pitch,yaw,bg_x"][head];
            let text = format!("{header}\n{body}");
            let errs = [
                read_imu_csv_from(text.as_bytes(), "f.csv").err(),
                read_gnss_csv_from(text.as_bytes(), "f.csv").err(),
                read_truth_csv_from(text.as_bytes(), "f.csv").err(),
            ];
            for e in errs.into_iter().flatten() {
                let msg = format!("{:#}", e);
                prop_assert!(msg.contains("f.csv"), "{}", msg);
            }
        }
    }
}

/// The contract between the trajectory simulator's writers (`hal_sim::trajectory::write`) and
/// these readers: a short simulated drive reads back whole, with every optional group present.
#[test]
fn simulated_drive_files_read_back_through_nav_io() {
    let dir = tempfile::tempdir().unwrap();
    let (n_imu, n_gnss) = hal_sim::trajectory::write::simulate_drive_files(
        0.02,
        100.0,
        1,
        (vec![(20.0, 30.0)], [0.0; 3]),
        dir.path(),
    )
    .unwrap();
    let imu = read_imu_csv(&dir.path().join("imu.csv")).unwrap();
    let truth = read_truth_csv(&dir.path().join("truth.csv")).unwrap();
    let gnss = read_gnss_csv(&dir.path().join("gnss.csv")).unwrap();
    assert_eq!((imu.len(), gnss.len()), (n_imu, n_gnss));
    assert_eq!(truth.len(), n_imu + 1, "truth from t = 0, IMU from t = dt");
    assert!(truth
        .iter()
        .all(|r| r.gyro_bias.is_some() && r.accel_bias.is_some()));
    assert!(gnss
        .iter()
        .all(|f| f.vel_ned.is_some() && f.sd_pos_ned.is_some() && f.sd_vel_ned.is_some()));
    assert!(!gnss.iter().any(|f| (20.0..30.0).contains(&f.t)));
}
