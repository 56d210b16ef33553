//! The five-point minimal solver of the essential matrix.
//!
//! Stewénius, Engels & Nistér, "Recent
//! developments on direct relative orientation", ISPRS J. 60 (2006), sec. 3 (the Gröbner-basis
//! form of Nistér's 5-point algorithm, PAMI 2004). Five correspondences give a 4-dimensional
//! null space `E = x X + y Y + z Z + W`; the 10 cubic constraints
//! `det E = 0` and `2 E E^T E - tr(E E^T) E = 0` (Nistér 2004) are written over the 20
//! monomials `x^3 .. 1`, Gauss-Jordan eliminated on the 10 cubic monomials, and the 10x10
//! action matrix of multiplication by `x` on the quotient basis
//! `[x^2, xy, y^2, xz, yz, z^2, x, y, z, 1]` has the solutions as eigenvectors (up to 10 real
//! roots).

use nalgebra::{Matrix3, Point2, SMatrix, SVector};

use super::RelPoseError;

// ---------------------------------------------------------------------------------------------
// Polynomials of degree <= 3 in (x, y, z), in the monomial order of Stewénius et al. (2006).

const N_MONO: usize = 20;
type Poly = [f64; N_MONO];

/// Exponents (x, y, z) of the monomials: the 10 cubic ones first, then the quotient basis.
const EXPONENTS: [[usize; 3]; N_MONO] = [
    [3, 0, 0],
    [2, 1, 0],
    [1, 2, 0],
    [0, 3, 0],
    [2, 0, 1],
    [1, 1, 1],
    [0, 2, 1],
    [1, 0, 2],
    [0, 1, 2],
    [0, 0, 3],
    [2, 0, 0],
    [1, 1, 0],
    [0, 2, 0],
    [1, 0, 1],
    [0, 1, 1],
    [0, 0, 2],
    [1, 0, 0],
    [0, 1, 0],
    [0, 0, 1],
    [0, 0, 0],
];

const fn build_index() -> [[[usize; 4]; 4]; 4] {
    let mut table = [[[usize::MAX; 4]; 4]; 4];
    let mut k = 0;
    while k < N_MONO {
        let e = EXPONENTS[k];
        table[e[0]][e[1]][e[2]] = k;
        k += 1;
    }
    table
}

/// `MONO_INDEX[a][b][c]` = position of `x^a y^b z^c` (`usize::MAX` for degree > 3).
const MONO_INDEX: [[[usize; 4]; 4]; 4] = build_index();

/// Product table: `PRODUCT[i][j]` = index of monomial i * monomial j, or `usize::MAX`.
const fn build_product() -> [[usize; N_MONO]; N_MONO] {
    let mut table = [[usize::MAX; N_MONO]; N_MONO];
    let mut i = 0;
    while i < N_MONO {
        let mut j = 0;
        while j < N_MONO {
            let a = EXPONENTS[i][0] + EXPONENTS[j][0];
            let b = EXPONENTS[i][1] + EXPONENTS[j][1];
            let c = EXPONENTS[i][2] + EXPONENTS[j][2];
            if a + b + c <= 3 {
                table[i][j] = MONO_INDEX[a][b][c];
            }
            j += 1;
        }
        i += 1;
    }
    table
}

const PRODUCT: [[usize; N_MONO]; N_MONO] = build_product();

/// Product of two polynomials whose product has degree <= 3 (terms above are dropped; the
/// callers only multiply degrees summing to <= 3).
fn poly_mul(a: &Poly, b: &Poly) -> Poly {
    let mut out = [0.0; N_MONO];
    for (i, &ai) in a.iter().enumerate() {
        if ai == 0.0 {
            continue;
        }
        for (j, &bj) in b.iter().enumerate() {
            if bj == 0.0 {
                continue;
            }
            if let Some(slot) = out.get_mut(PRODUCT[i][j]) {
                *slot += ai * bj;
            }
        }
    }
    out
}

fn poly_add(a: &Poly, b: &Poly) -> Poly {
    let mut out = *a;
    for (o, v) in out.iter_mut().zip(b) {
        *o += v;
    }
    out
}

fn poly_scale(a: &Poly, s: f64) -> Poly {
    let mut out = *a;
    for o in &mut out {
        *o *= s;
    }
    out
}

/// The 5-point minimal solver (module docs): all real essential matrices `E` (unit Frobenius
/// norm) with `x_a[i]^T E x_b[i] = 0` for the five correspondences. Up to 10 solutions; an
/// empty vector when the sample is degenerate.
///
/// # Errors
/// [`RelPoseError::NonFinite`].
pub fn essential_five_point(
    x_a: &[Point2<f64>; 5],
    x_b: &[Point2<f64>; 5],
) -> Result<Vec<Matrix3<f64>>, RelPoseError> {
    for (i, (a, b)) in x_a.iter().zip(x_b).enumerate() {
        if !(a
            .coords
            .iter()
            .chain(b.coords.iter())
            .all(|c| c.is_finite()))
        {
            return Err(RelPoseError::NonFinite { index: i });
        }
    }
    // Epipolar constraints, row-major vec(E), padded to 9x9 for a full right singular basis.
    let mut q = SMatrix::<f64, 9, 9>::zeros();
    for (r, (a, b)) in x_a.iter().zip(x_b).enumerate() {
        let xa = [a.x, a.y, 1.0];
        let xb = [b.x, b.y, 1.0];
        for m in 0..3 {
            for n in 0..3 {
                q[(r, 3 * m + n)] = xa[m] * xb[n];
            }
        }
    }
    let Some(svd) = nalgebra::SVD::try_new(q, false, true, f64::EPSILON, 1000) else {
        return Ok(Vec::new());
    };
    let Some(v_t) = svd.v_t else {
        return Ok(Vec::new());
    };
    let s = svd.singular_values;
    if s[4] <= 1e-10 * s[0] {
        return Ok(Vec::new()); // fewer than 5 independent constraints
    }
    let basis = |row: usize| -> Matrix3<f64> { Matrix3::from_fn(|m, n| v_t[(row, 3 * m + n)]) };
    let (bx, by, bz, bw) = (basis(5), basis(6), basis(7), basis(8));
    // E entries as linear polynomials.
    let mut e = [[[0.0; N_MONO]; 3]; 3];
    for (m, row) in e.iter_mut().enumerate() {
        for (n, p) in row.iter_mut().enumerate() {
            p[16] = bx[(m, n)];
            p[17] = by[(m, n)];
            p[18] = bz[(m, n)];
            p[19] = bw[(m, n)];
        }
    }
    // E E^T (quadratic, symmetric).
    let mut eet = [[[0.0; N_MONO]; 3]; 3];
    for i in 0..3 {
        for j in i..3 {
            let mut acc = [0.0; N_MONO];
            for (eik, ejk) in e[i].iter().zip(&e[j]) {
                acc = poly_add(&acc, &poly_mul(eik, ejk));
            }
            eet[i][j] = acc;
            eet[j][i] = acc;
        }
    }
    let trace = poly_add(&poly_add(&eet[0][0], &eet[1][1]), &eet[2][2]);
    let mut rows: Vec<Poly> = Vec::with_capacity(10);
    for (e_row_i, eet_row_i) in e.iter().zip(&eet) {
        for (j, e_ij) in e_row_i.iter().enumerate() {
            let mut acc = [0.0; N_MONO];
            for (eet_ik, e_row_k) in eet_row_i.iter().zip(&e) {
                acc = poly_add(&acc, &poly_mul(eet_ik, &e_row_k[j]));
            }
            let trace_e = poly_mul(&trace, e_ij);
            rows.push(poly_add(
                &poly_scale(&acc, 2.0),
                &poly_scale(&trace_e, -1.0),
            ));
        }
    }
    let minor = |r1: usize, c1: usize, r2: usize, c2: usize| {
        poly_add(
            &poly_mul(&e[r1][c1], &e[r2][c2]),
            &poly_scale(&poly_mul(&e[r1][c2], &e[r2][c1]), -1.0),
        )
    };
    let det = poly_add(
        &poly_add(
            &poly_mul(&e[0][0], &minor(1, 1, 2, 2)),
            &poly_scale(&poly_mul(&e[0][1], &minor(1, 0, 2, 2)), -1.0),
        ),
        &poly_mul(&e[0][2], &minor(1, 0, 2, 1)),
    );
    rows.push(det);
    // Gauss-Jordan on the cubic monomials: B = L^-1 R.
    let mut l = SMatrix::<f64, 10, 10>::zeros();
    let mut rr = SMatrix::<f64, 10, 10>::zeros();
    for (r, p) in rows.iter().enumerate() {
        for c in 0..10 {
            l[(r, c)] = p[c];
            rr[(r, c)] = p[c + 10];
        }
    }
    let lu = l.lu();
    let Some(b) = lu.solve(&rr) else {
        return Ok(Vec::new());
    };
    if !b.iter().all(|v| v.is_finite()) {
        return Ok(Vec::new());
    }
    // Action matrix of x on [x^2, xy, y^2, xz, yz, z^2, x, y, z, 1].
    let mut action = SMatrix::<f64, 10, 10>::zeros();
    for (row, cubic) in [(0usize, 0usize), (1, 1), (2, 2), (3, 4), (4, 5), (5, 7)] {
        for c in 0..10 {
            action[(row, c)] = -b[(cubic, c)];
        }
    }
    action[(6, 0)] = 1.0;
    action[(7, 1)] = 1.0;
    action[(8, 3)] = 1.0;
    action[(9, 6)] = 1.0;
    let Some(schur) = nalgebra::Schur::try_new(action, f64::EPSILON, 10_000) else {
        return Ok(Vec::new());
    };
    let eigenvalues = schur.complex_eigenvalues();
    let mut out = Vec::new();
    let mut seen: Vec<f64> = Vec::new();
    for ev in eigenvalues.iter() {
        if ev.im.abs() > 1e-8 * (1.0 + ev.re.abs()) {
            continue;
        }
        let lambda = ev.re;
        if seen
            .iter()
            .any(|s| (s - lambda).abs() <= 1e-12 * (1.0 + lambda.abs()))
        {
            continue;
        }
        seen.push(lambda);
        let Some(v) = eigenvector(&action, lambda) else {
            continue;
        };
        if v[9].abs() <= 1e-14 * v.norm() {
            continue;
        }
        let (x, y, z) = (v[6] / v[9], v[7] / v[9], v[8] / v[9]);
        let em = bx * x + by * y + bz * z + bw;
        let norm = em.norm();
        if norm > 0.0 && norm.is_finite() {
            out.push(em / norm);
        }
    }
    Ok(out)
}

/// Eigenvector of `a` for the real eigenvalue `lambda`: two steps of inverse iteration with a
/// tiny shift (one LU), checked by its residual; the SVD null vector of `a - lambda I` when
/// that fails.
fn eigenvector(a: &SMatrix<f64, 10, 10>, lambda: f64) -> Option<SVector<f64, 10>> {
    let scale = 1.0 + lambda.abs();
    let shifted = a - SMatrix::<f64, 10, 10>::identity() * (lambda + 1e-10 * scale);
    let lu = shifted.lu();
    let residual_ok = |v: &SVector<f64, 10>| {
        let n = v.norm();
        n > 0.0 && n.is_finite() && (a * v - v * lambda).norm() <= 1e-9 * scale * n
    };
    if let Some(v1) = lu.solve(&SVector::<f64, 10>::repeat(1.0)) {
        let n1 = v1.norm();
        if n1 > 0.0
            && n1.is_finite()
            && let Some(v2) = lu.solve(&(v1 / n1))
            && residual_ok(&v2)
        {
            return Some(v2);
        }
    }
    let shifted = a - SMatrix::<f64, 10, 10>::identity() * lambda;
    let svd = nalgebra::SVD::try_new(shifted, false, true, f64::EPSILON, 1000)?;
    let v: SVector<f64, 10> = svd.v_t?.row(9).transpose();
    residual_ok(&v).then_some(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn monomial_tables_are_consistent() {
        for (k, e) in EXPONENTS.iter().enumerate() {
            assert_eq!(MONO_INDEX[e[0]][e[1]][e[2]], k);
        }
        // x * x^2 = x^3, y * xz = xyz, 1 * 1 = 1, x^2 * x^2 is dropped (degree 4).
        assert_eq!(PRODUCT[16][10], 0);
        assert_eq!(PRODUCT[17][13], 5);
        assert_eq!(PRODUCT[19][19], 19);
        assert_eq!(PRODUCT[10][10], usize::MAX);
    }

    #[test]
    fn polynomial_product_expands_correctly() {
        // (x + 2)(y - 1) = xy - x + 2y - 2.
        let mut p = [0.0; N_MONO];
        p[16] = 1.0;
        p[19] = 2.0;
        let mut q = [0.0; N_MONO];
        q[17] = 1.0;
        q[19] = -1.0;
        let r = poly_mul(&p, &q);
        let mut expected = [0.0; N_MONO];
        expected[11] = 1.0;
        expected[16] = -1.0;
        expected[17] = 2.0;
        expected[19] = -2.0;
        assert_eq!(r, expected);
    }
}
