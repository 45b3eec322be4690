//! The unit tests of `src/analysis/` and `src/io/`: the blocked statistics, plot ticks,
//! split file writes and the list of temporary files.
//! (Moved from the library's own unit tests: the integration suite is built once.)

mod stats {
    use g1tess::eval::PairProducts;
    use g1tess::internals::{Part, BLOCK_PAIRS};
    use g1tess::mesh::creases::normal_key;
    use g1tess::mesh::LoadOptions;
    use g1tess::mesh::Mesh;
    use g1tess::patch::g1::any_split_normals;

    /// The serial search [`any_split_normals`] replaced: each vertex's first corner in
    /// triangle order is its representative.
    fn serial_split_normals(mesh: &Mesh) -> bool {
        let mut first = vec![u32::MAX; mesh.positions.len()];
        for (t, (tri, normals)) in mesh.triangles.iter().zip(&mesh.corner_normals).enumerate() {
            for k in 0..3 {
                let f = &mut first[tri[k] as usize];
                if *f == u32::MAX {
                    *f = (3 * t + k) as u32;
                    continue;
                }
                let (ft, fk) = (*f as usize / 3, *f as usize % 3);
                if normal_key(mesh.corner_normals[ft][fk]) != normal_key(normals[k]) {
                    return true;
                }
            }
        }
        false
    }

    #[test]
    fn block_parts_are_those_of_pushing_in_order() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let special = [0.0, -0.0, f64::NAN, -1.0, 1.0, 1.0000000000000004, -0.5];
        let bits = |p: &Part| {
            (
                [p.n, p.folded, p.crease_n],
                [
                    p.shift,
                    p.s1,
                    p.s2,
                    p.min,
                    p.max,
                    p.worst_abs,
                    p.gap2,
                    p.crease_gap2,
                ]
                .map(f64::to_bits),
            )
        };
        for len in [0, 1, 2, 3, 17, BLOCK_PAIRS] {
            for mix in 0..6 {
                let samples: Vec<PairProducts> = (0..len)
                    .map(|_| {
                        let r = next();
                        let u = (r >> 11) as f64 / (1u64 << 53) as f64;
                        let pick = special[(r % 7) as usize];
                        let cos = match mix {
                            // Near 1 (a smooth surface), then anywhere in [−1, 1].
                            0 => 1.0 - 1e-6 * u,
                            1 => 2.0 * u - 1.0,
                            // Special values among ordinary ones, then only those.
                            2 if r % 5 == 0 => pick,
                            2 => 2.0 * u - 1.0,
                            3 => pick,
                            // Zeros of both signs only (the order-dependent extremes).
                            4 => special[(r % 2) as usize],
                            _ => f64::NAN,
                        };
                        let gap2 = if mix == 3 && r % 3 == 0 {
                            f64::NAN
                        } else {
                            u * 1e-30
                        };
                        PairProducts { cos, gap2 }
                    })
                    .collect();
                let mut pushed = Part::new();
                for &s in &samples {
                    pushed.push(s, false);
                }
                assert_eq!(
                    bits(&Part::of(&samples)),
                    bits(&pushed),
                    "{len} samples, mix {mix}"
                );
            }
        }
    }

    #[test]
    fn parallel_split_search_agrees_with_the_serial_one() {
        let mut seen = [false; 2];
        for name in ["fandisk.obj", "suzanne.obj", "spot.obj"] {
            for crease in [None, Some(30.0)] {
                let opts = LoadOptions::default()
                    .with_recompute_normals(crease.is_some())
                    .with_crease_angle(crease);
                let path = format!("{}/tests/data/{name}", env!("CARGO_MANIFEST_DIR"));
                let mut mesh = Mesh::load(&path, &opts).unwrap();
                for round in 0..2 {
                    let expect = serial_split_normals(&mesh);
                    seen[expect as usize] = true;
                    for threads in [1, 2, 3] {
                        let pool = rayon::ThreadPoolBuilder::new()
                            .num_threads(threads)
                            .build()
                            .unwrap();
                        let got = pool.install(|| any_split_normals(&mesh));
                        assert_eq!(got, expect, "{name} {crease:?} round {round}");
                    }
                    // One corner normal of the last triangle turned a little: a split there.
                    let last = mesh.corner_normals.last_mut().unwrap();
                    last[2] = (last[2] + glam::DVec3::new(0.0, 1e-3, 0.0)).normalize();
                }
            }
        }
        assert_eq!(seen, [true, true]);
    }
}

#[cfg(feature = "cli")]
mod plot {
    use g1tess::io::plot::log_ticks;

    /// The sphere's x range (20 to 5120 triangles with the 1.6 margin): 1, 2, 5 × 10^k,
    /// eight labels; minor lines at the other mantissas, never on a label.
    #[test]
    fn log_ticks_label_key_points() {
        let (bold, light) = log_ticks(20.0 / 1.6, 5120.0 * 1.6);
        assert_eq!(
            bold,
            [20.0, 50.0, 100.0, 200.0, 500.0, 1000.0, 2000.0, 5000.0]
        );
        // 20..90, 100..900, 1000..8000 (25 mantissa points), less the 8 labels.
        assert_eq!(light.len(), 8 + 9 + 8 - 8, "{light:?}");
        assert!(light.iter().all(|v| !bold.contains(v)));
        assert!(light.contains(&30.0) && light.contains(&8000.0) && !light.contains(&10.0));
        // The y range of the study (1e-8..0.2, seven decades): decades only, minor lines.
        let (bold, light) = log_ticks(5e-9, 0.2);
        assert_eq!(bold, [1e-8, 1e-7, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1]);
        // 5e-9..9e-9, seven full decades 1e-8..9e-2, 1e-1 and 2e-1, less the 8 labels.
        assert_eq!(light.len(), 5 + 7 * 9 + 2 - 8, "{light:?}");
        // Under a decade: every integer mantissa labelled, at least four labels.
        let (bold, light) = log_ticks(3.5, 9.5);
        assert_eq!(bold, [4.0, 5.0, 6.0, 7.0, 8.0, 9.0]);
        assert!(light.is_empty());
        // Twelve decades: decades only, no minor lines.
        let (bold, light) = log_ticks(1e-12, 1.0);
        assert_eq!(bold.len(), 13);
        assert!(light.is_empty());
        // Not a log range: nothing.
        assert_eq!(log_ticks(0.0, 1.0), (vec![], vec![]));
    }
}

mod atomic {
    use std::fs::File;
    use std::io::Write;

    use std::path::Path;

    use g1tess::internals::DIRECT_ALIGN;
    use g1tess::io::atomic::{write_atomic, PipedWriter};
    use g1tess::io::TempFiles;

    /// A write lists its temporary file in the `TempFiles` it is given (shared by clones,
    /// not by another list) while it runs; removing the live files deletes it, the write
    /// then fails without creating the target, and later writes through that list are
    /// refused while another list still writes.
    #[test]
    fn temp_files_list_live_writes_and_remove_them() {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("unit_output_temp_files");
        std::fs::create_dir_all(&dir).unwrap();
        let target = dir.join("out.txt");
        let _ = std::fs::remove_file(&target);
        let tmp = dir.join(format!(".out.txt.tmp-{}", std::process::id()));
        let (temp, other) = (TempFiles::default(), TempFiles::default());
        let handle = temp.clone();
        let result = write_atomic(&target, &temp, |w| {
            w.write_all(b"partial")?;
            w.flush()?;
            assert_eq!(handle.live_temp_files(), vec![tmp.clone()]);
            assert!(other.live_temp_files().is_empty());
            assert!(tmp.is_file());
            assert_eq!(handle.remove_live_temp_files(), vec![tmp.clone()]);
            Ok(())
        });
        assert!(result.is_err(), "the rename of a removed file must fail");
        assert!(!tmp.exists() && !target.exists());
        assert!(temp.live_temp_files().is_empty());
        let refused = write_atomic(&target, &temp, |w| w.write_all(b"late")).unwrap_err();
        assert!(
            refused.to_string().contains("the process is exiting"),
            "{refused}"
        );
        assert!(!target.exists());
        write_atomic(&target, &other, |w| w.write_all(b"whole")).unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"whole");
        assert!(other.live_temp_files().is_empty());
        std::fs::remove_file(&target).unwrap();
    }

    /// A stream (with or without an unaligned flush half way, which turns direct I/O off),
    /// a second writer from a page boundary on, and the second's rest written at the end
    /// give exactly the bytes written, whether the file system takes direct I/O or not.
    #[test]
    fn piped_and_split_writes_land_in_place() {
        let data: Vec<u8> = (0..5_000_000u32)
            .map(|i| (i.wrapping_mul(2_654_435_761) >> 24) as u8)
            .collect();
        // A page boundary; the second writer gets one whole block and a rest.
        let split = 301 * DIRECT_ALIGN;
        for flush in [false, true] {
            let path =
                std::env::temp_dir().join(format!("g1tess-piped-{}-{flush}", std::process::id()));
            let mut w = PipedWriter::spawn(File::create(&path).unwrap());
            let mut side = w.split_at(split as u64).unwrap();
            side.write_all(&data[split..]).unwrap();
            w.write_all(&data[..1000]).unwrap();
            if flush {
                w.flush().unwrap();
            }
            w.write_all(&data[1000..split]).unwrap();
            let (at, rest) = side.finish_at().unwrap();
            assert_eq!(at as usize + rest.len(), data.len());
            w.write_at_end(at, rest);
            drop(w.finish().unwrap());
            let got = std::fs::read(&path).unwrap();
            std::fs::remove_file(&path).unwrap();
            assert!(got == data, "flush {flush}: the file differs");
        }
    }
}
