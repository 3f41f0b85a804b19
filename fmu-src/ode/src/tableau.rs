//! Rosenbrock (Rodas) coefficient sets in the "transformed" form of Hairer & Wanner
//! (Solving ODEs II, 2nd ed., Sec. IV.7, eq. (7.4')/(7.25)):
//!
//! ```text
//! (I/(h*gamma) - J) k_i = f(t + c_i h, y + sum_j a_ij k_j) + d_i h f_t + sum_j (C_ij / h) k_j
//! y_1 = y + sum_j b_j k_j,      error estimate = k_s (the last stage)
//! ```
//!
//! Both methods are stiffly accurate: the last rows of `a` equal `b` minus the trailing stages,
//! so `y_1` is the argument of the last stage plus `k_s` and the embedded solution is that argument.
//! The rows that the papers write as "u <- u + k_i" appear here expanded into full rows of `a`
//! with unit entries.

/// One Rosenbrock coefficient set (stage count `s`).
pub(crate) struct Tableau {
    /// Number of stages `s`.
    pub stages: usize,
    /// Diagonal coefficient gamma of `W = I/(h gamma) - J`.
    pub gamma: f64,
    /// `a[i]` holds `a_i0 .. a_i(i-1)` (stage argument weights).
    pub a: &'static [&'static [f64]],
    /// `cc[i]` holds `C_i0 .. C_i(i-1)` (weights of previous stages in the right-hand side).
    pub cc: &'static [&'static [f64]],
    /// Stage time nodes `c_i`.
    pub c: &'static [f64],
    /// Time-derivative weights `d_i` (= gamma_i, the row sums of Gamma).
    pub d: &'static [f64],
    /// Solution weights `b_j`.
    pub b: &'static [f64],
    /// The error estimate `k_s` is O(h^q); the step controller uses exponent 1/q.
    pub err_order: i32,
}

// ---------------------------------------------------------------------------------------------
// Rodas4: Hairer & Wanner, Solving ODEs II, Sec. IV.7, Table 7.2 coefficients in the
// transformed form used by the Fortran code RODAS (E. Hairer, G. Wanner, 1996; coefficient
// set "METH=1"). Order 4, embedded order 3, L-stable, stiffly accurate, gamma = 1/4.
// ---------------------------------------------------------------------------------------------
const R4_A51: f64 = 1.221224509226641;
const R4_A52: f64 = 6.019134481288629;
const R4_A53: f64 = 12.53708332932087;
const R4_A54: f64 = -0.687_886_036_105_895;

pub(crate) static RODAS4: Tableau = Tableau {
    stages: 6,
    gamma: 0.25,
    a: &[
        &[],
        &[1.544],
        &[0.9466785280815826, 0.2557011698983284],
        &[3.314825187068521, 2.896124015972201, 0.9986419139977817],
        &[R4_A51, R4_A52, R4_A53, R4_A54],
        &[R4_A51, R4_A52, R4_A53, R4_A54, 1.0],
    ],
    cc: &[
        &[],
        &[-5.6688],
        &[-2.430093356833875, -0.2063599157091915],
        &[-0.1073529058151375, -9.594562251023355, -20.47028614809616],
        &[
            7.496443313967647,
            -10.24680431464352,
            -33.99990352819905,
            11.7089089320616,
        ],
        &[
            8.083246795921522,
            -7.981132988064893,
            -31.52159432874371,
            16.31930543123136,
            -6.058818238834054,
        ],
    ],
    c: &[0.0, 0.386, 0.21, 0.63, 1.0, 1.0],
    d: &[0.25, -0.1043, 0.1035, -0.036_200_000_000_000_23, 0.0, 0.0],
    b: &[R4_A51, R4_A52, R4_A53, R4_A54, 1.0, 1.0],
    err_order: 4,
};

// ---------------------------------------------------------------------------------------------
// Rodas5P: G. Steinebach, "Construction of Rosenbrock-Wanner method Rodas5P and numerical
// benchmarks within the Julia Differential Equations package", BIT Numer. Math. 63 (2023) 27.
// Order 5, embedded order 4, L-stable, stiffly accurate, 8 stages.
// ---------------------------------------------------------------------------------------------
const P_A61: f64 = -7.502846399306121;
const P_A62: f64 = 2.561846144803919;
const P_A63: f64 = -11.627539656261098;
const P_A64: f64 = -0.18268767659942256;
const P_A65: f64 = 0.030198172008377946;

pub(crate) static RODAS5P: Tableau = Tableau {
    stages: 8,
    gamma: 0.21193756319429014,
    a: &[
        &[],
        &[3.0],
        &[2.849394379747939, 0.45842242204463923],
        &[-6.954028509809101, 2.489845061869568, -10.358996098473584],
        &[
            2.8029986275628964,
            0.5072464736228206,
            -0.3988312541770524,
            -0.04721187230404641,
        ],
        &[P_A61, P_A62, P_A63, P_A64, P_A65],
        &[P_A61, P_A62, P_A63, P_A64, P_A65, 1.0],
        &[P_A61, P_A62, P_A63, P_A64, P_A65, 1.0, 1.0],
    ],
    cc: &[
        &[],
        &[-14.155112264123755],
        &[-17.97296035885952, -2.859693295451294],
        &[147.12150275711716, -1.41221402718213, 71.68940251302358],
        &[
            165.43517024871676,
            -0.4592823456491126,
            42.90938336958603,
            -5.961986721573306,
        ],
        &[
            24.854864614690072,
            -3.0009227002832186,
            47.4931110020768,
            5.5814197821558125,
            -0.6610691825249471,
        ],
        &[
            30.91273214028599,
            -3.1208243349937974,
            77.79954646070892,
            34.28646028294783,
            -19.097331116725623,
            -28.087943162872662,
        ],
        &[
            37.80277123390563,
            -3.2571969029072276,
            112.26918849496327,
            66.9347231244047,
            -40.06618937091002,
            -54.66780262877968,
            -9.48861652309627,
        ],
    ],
    c: &[
        0.0,
        0.6358126895828704,
        0.4095798393397535,
        0.9769306725060716,
        0.4288403609558664,
        1.0,
        1.0,
        1.0,
    ],
    d: &[
        0.21193756319429014,
        -0.42387512638858027,
        -0.3384627126235924,
        1.8046452872882734,
        2.325825639765069,
        0.0,
        0.0,
        0.0,
    ],
    b: &[P_A61, P_A62, P_A63, P_A64, P_A65, 1.0, 1.0, 1.0],
    err_order: 5,
};

#[cfg(test)]
mod tests {
    use super::{RODAS4, RODAS5P};
    use nalgebra::{DMatrix, DVector};

    /// Recover the original Rosenbrock matrix Gamma from the transformed coefficients
    /// (Hairer-Wanner IV.7: C = diag(1/gamma) - Gamma^{-1}, a = alpha Gamma^{-1}, b = m) and check
    /// the order-1 consistency conditions that catch a mistyped coefficient:
    /// Gamma 1 = d (gamma_i row sums), alpha 1 = c (stage times), sum of original weights = 1.
    #[test]
    fn coefficients_are_consistent() {
        for tab in [&RODAS4, &RODAS5P] {
            let s = tab.stages;
            assert_eq!(tab.a.len(), s);
            assert_eq!(tab.cc.len(), s);
            let mut ginv = DMatrix::<f64>::zeros(s, s);
            let mut a = DMatrix::<f64>::zeros(s, s);
            for i in 0..s {
                assert_eq!(tab.a[i].len(), i);
                assert_eq!(tab.cc[i].len(), i);
                ginv[(i, i)] = 1.0 / tab.gamma;
                for j in 0..i {
                    ginv[(i, j)] = -tab.cc[i][j];
                    a[(i, j)] = tab.a[i][j];
                }
            }
            let gamma = ginv.try_inverse().expect("Gamma^-1 invertible");
            let ones = DVector::<f64>::from_element(s, 1.0);
            let row_sums = &gamma * &ones;
            for i in 0..s {
                assert!(
                    (row_sums[i] - tab.d[i]).abs() < 1e-9,
                    "d_{i}: {} vs {}",
                    row_sums[i],
                    tab.d[i]
                );
            }
            let alpha = &a * &gamma;
            let c = &alpha * &ones;
            for i in 0..s {
                assert!(
                    (c[i] - tab.c[i]).abs() < 1e-9,
                    "c_{i}: {} vs {}",
                    c[i],
                    tab.c[i]
                );
            }
            let b = DVector::from_column_slice(tab.b);
            let orig_b = gamma.transpose() * b;
            assert!(
                (orig_b.sum() - 1.0).abs() < 1e-9,
                "sum b = {}",
                orig_b.sum()
            );
        }
    }
}
