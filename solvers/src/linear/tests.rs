use super::*;
use crate::assembly::Pattern;
use nalgebra::Matrix6;

#[test]
fn solves_laplacian_like_system() {
    // A 2x2 grid of 8 triangles: blocks = cotan-like PSD blocks + identity shift makes SPD.
    let faces = vec![[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]];
    let pat = Pattern::new(&faces, 5);
    let blocks: Vec<Matrix6<f64>> = (0..faces.len())
        .map(|t| {
            let b = Matrix6::from_fn(|i, j| (((i + 1) * (j + 2) + t) % 5) as f64 * 0.1);
            b * b.transpose() + Matrix6::identity()
        })
        .collect();
    let mut vals = Vec::new();
    pat.assemble(&blocks, &mut vals);
    let x_true: Vec<f64> = (0..10).map(|i| (i as f64).cos()).collect();
    let b = pat.sym_mul(&vals, &x_true);
    let mut solver = SpdSolver::new(&pat, Ordering::Amd).unwrap();
    for jacobi in [false, true] {
        let x = solver.solve(&vals, &b, &LinearSettings { tikhonov: 0.0, jacobi, ..Default::default() }).unwrap();
        for i in 0..10 {
            assert!((x[i] - x_true[i]).abs() < 1e-10, "{jacobi} {i}");
        }
    }
    // refactorization with new values reuses the analysis
    let vals2: Vec<f64> = vals.iter().map(|v| 2.0 * v).collect();
    let x = solver.solve(&vals2, &b, &LinearSettings::default()).unwrap();
    assert!((x[3] - 0.5 * x_true[3]).abs() < 1e-8);
}

/// A generated mesh, its Newton pattern and SPD values on it (PSD element blocks plus
/// `shift` times the identity).
fn spd_system(name: &str, shift: f64) -> (crate::mesh::Mesh, Pattern, Vec<f64>) {
    let mesh = crate::generate::generate(name).unwrap();
    let pat = Pattern::new(&mesh.faces, mesh.n_vertices());
    let blocks: Vec<Matrix6<f64>> = (0..mesh.n_faces())
        .map(|t| {
            let b = Matrix6::from_fn(|i, j| ((i * 7 + j * 3 + t) % 11) as f64 * 0.1 - 0.5);
            b * b.transpose() + Matrix6::identity() * shift
        })
        .collect();
    let mut vals = Vec::new();
    pat.assemble(&blocks, &mut vals);
    (mesh, pat, vals)
}

#[test]
fn metis_and_amd_orderings_solve_the_same_system_and_metis_fills_less() {
    let (_, pat, vals) = spd_system("bumpy_10k", 1e-3);
    let x_true: Vec<f64> = (0..pat.n).map(|i| (i as f64 * 0.01).sin()).collect();
    let b = pat.sym_mul(&vals, &x_true);
    let settings = LinearSettings { tikhonov: 0.0, jacobi: true, ..Default::default() };
    let mut metis = SpdSolver::new(&pat, Ordering::Metis).unwrap();
    let mut amd = SpdSolver::new(&pat, Ordering::Amd).unwrap();
    assert_eq!((metis.ordering(), amd.ordering()), (Ordering::Metis, Ordering::Amd));
    let (xm, xa) = (metis.solve(&vals, &b, &settings).unwrap(), amd.solve(&vals, &b, &settings).unwrap());
    let err = |x: &[f64]| x.iter().zip(&x_true).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(err(&xm) < 1e-8 && err(&xa) < 1e-8, "{} {}", err(&xm), err(&xa));
    // nested dissection: less fill than AMD on a 10k-vertex mesh (rust-stack.md: ~20% at 71k)
    assert!(metis.factor_len() < amd.factor_len(), "{} vs {}", metis.factor_len(), amd.factor_len());
}

/// Several right-hand sides solved in one pass give each column's own solution; a length
/// that is not whole columns is a typed error.
#[test]
fn columns_are_solved_together() {
    let (_, pat, vals) = spd_system("bumpy_5k", 1e-3);
    let settings = LinearSettings { tikhonov: 1e-10, jacobi: true, ..Default::default() };
    let mut solver = SpdSolver::new(&pat, Ordering::Metis).unwrap();
    solver.factorize(&vals, &settings).unwrap();
    let cols: Vec<Vec<f64>> =
        (0..3).map(|k| (0..pat.n).map(|i| ((i * (k + 2)) as f64 * 0.013).sin()).collect()).collect();
    let mut together: Vec<f64> = cols.concat();
    solver.solve_columns_in_place(&mut together).unwrap();
    for (k, b) in cols.iter().enumerate() {
        let alone = solver.solve_factored(b).unwrap();
        let got = &together[k * pat.n..][..pat.n];
        let scale = alone.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let err = alone.iter().zip(got).fold(0.0f64, |a, (x, y)| a.max((x - y).abs()));
        assert!(err <= 1e-12 * scale, "column {k}: {err:e} of {scale:e}");
        // and it solves the system: A x = b
        let ax = pat.sym_mul(&vals, got);
        let res = ax.iter().zip(b).fold(0.0f64, |a, (x, y)| a.max((x - y).abs()));
        assert!(res <= 1e-8, "column {k}: residual {res:e}");
    }
    let mut ragged = vec![1.0; pat.n + 1];
    let e = solver.solve_columns_in_place(&mut ragged).unwrap_err();
    assert_eq!(e, LinearError::RhsLength { rows: pat.n, len: pat.n + 1 });
}

#[test]
fn indefinite_matrix_is_a_typed_error() {
    let faces = vec![[0, 1, 2]];
    let pat = Pattern::new(&faces, 3);
    let blocks = vec![-Matrix6::<f64>::identity()];
    let mut vals = Vec::new();
    pat.assemble(&blocks, &mut vals);
    let mut solver = SpdSolver::new(&pat, Ordering::Amd).unwrap();
    let b = vec![1.0; 6];
    let err =
        solver.solve(&vals, &b, &LinearSettings { tikhonov: 0.0, jacobi: false, ..Default::default() }).unwrap_err();
    assert!(matches!(err, LinearError::NotPositiveDefinite { .. }));
    let err = solver.solve(&vals, &b, &LinearSettings::default()).unwrap_err();
    assert!(matches!(err, LinearError::BadDiagonal { .. }));
}

#[test]
fn a_cache_shares_one_analysis_per_pattern_and_ordering_and_solves_the_same() {
    let (mesh, pat, vals) = spd_system("bumpy_1k", 1e-2);
    let b: Vec<f64> = (0..pat.n).map(|i| (i as f64 * 0.3).cos()).collect();
    let settings = LinearSettings::default();

    let cache = AnalysisCache::new();
    let mut first = SpdSolver::shared(&pat, Ordering::Metis, Some(&cache)).unwrap();
    let mut second = SpdSolver::shared(&pat, Ordering::Metis, Some(&cache)).unwrap();
    assert!(!first.analysis_reused() && second.analysis_reused());
    assert!(Arc::ptr_eq(first.analysis(), second.analysis()));
    assert!(first.analysis().seconds() > 0.0);
    assert_eq!(cache.len(), 1);
    // another ordering or another pattern is another entry
    let amd = SpdSolver::shared(&pat, Ordering::Amd, Some(&cache)).unwrap();
    assert!(!amd.analysis_reused() && amd.ordering() == Ordering::Amd);
    let half = Pattern::new(&mesh.faces[..mesh.n_faces() / 2], mesh.n_vertices());
    assert!(!SpdSolver::shared(&half, Ordering::Metis, Some(&cache)).unwrap().analysis_reused());
    assert_eq!(cache.len(), 3);
    // a failed analysis (a block size that does not divide the dofs) is reported to each
    // caller and never stored
    for _ in 0..2 {
        let err = cache.get(pat.n, &pat.col_ptr, &pat.row_idx, Ordering::Metis, pat.n + 1).err();
        assert!(matches!(err, Some(LinearError::Symbolic(_))), "{err:?}");
    }
    assert_eq!(cache.len(), 3);
    // bit-identical solutions from the shared and a private analysis
    let mut private = SpdSolver::new(&pat, Ordering::Metis).unwrap();
    let x = private.solve(&vals, &b, &settings).unwrap();
    assert_eq!(first.solve(&vals, &b, &settings).unwrap(), x);
    assert_eq!(second.solve(&vals, &b, &settings).unwrap(), x);
}

#[test]
fn concurrent_requests_for_one_pattern_analyse_it_once() {
    let mesh = crate::generate::generate("bumpy_1k").unwrap();
    let pat = Pattern::new(&mesh.faces, mesh.n_vertices());
    let cache = AnalysisCache::new();
    let reused: Vec<bool> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..4)
            .map(|_| s.spawn(|| SpdSolver::shared(&pat, Ordering::Metis, Some(&cache)).unwrap().analysis_reused()))
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    assert_eq!(reused.iter().filter(|r| !**r).count(), 1, "{reused:?}");
    assert_eq!(cache.len(), 1);
}
