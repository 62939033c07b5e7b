//! `vbap formation`: the optimal formation (V.7) of N vehicles for a Hessian guess and the
//! noise levels: g, the positions, the radius and the second moments.

use anyhow::Result;
use clap::Args;
use vbap_ipc::process::EXIT_OK;
use vbap_math::Mat3;

use crate::errors::InvalidInput;

/// Arguments.
#[derive(Args, Debug)]
pub struct FormationArgs {
    /// Number of vehicles.
    #[arg(long)]
    n: usize,
    /// Dimension, 2 or 3.
    #[arg(long, default_value_t = 2)]
    dim: usize,
    /// σ_M, the sensor noise standard deviation.
    #[arg(long, default_value_t = 1.0)]
    sigma_m: f64,
    /// σ_H, the standard deviation of the Hessian factor.
    #[arg(long, default_value_t = 1.0)]
    sigma_h: f64,
    /// The Hessian guess H: h11,h12,h21,h22 (2-D) or 9 numbers row by row (3-D). Default I.
    #[arg(long, allow_hyphen_values = true, value_delimiter = ',')]
    hessian: Option<Vec<f64>>,
    /// Seed of the multi-start search.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

/// The `--hessian` numbers, row by row, as a dim×dim matrix (the rest zero).
fn hessian_matrix(values: &[f64], dim: usize) -> Result<Mat3> {
    if values.len() != dim * dim || values.iter().any(|v| !v.is_finite()) {
        let text: Vec<String> = values.iter().map(f64::to_string).collect();
        return Err(InvalidInput(format!(
            "--hessian {}: needs {} finite numbers for dim {dim}",
            text.join(","),
            dim * dim
        ))
        .into());
    }
    let mut h = Mat3::zeros();
    for i in 0..dim {
        for j in 0..dim {
            h[(i, j)] = values[i * dim + j];
        }
    }
    Ok(h)
}

/// Runs the command; returns the exit code.
pub fn main(args: &FormationArgs) -> Result<i32> {
    if args.dim != 2 && args.dim != 3 {
        return Err(InvalidInput(format!("--dim {}: must be 2 or 3", args.dim)).into());
    }
    if args.n < args.dim + 1 || args.n > vbap_ipc::msg::MAX_VEHICLES {
        return Err(InvalidInput(format!(
            "--n {}: must be between dim + 1 = {} and {}",
            args.n,
            args.dim + 1,
            vbap_ipc::msg::MAX_VEHICLES
        ))
        .into());
    }
    for (name, v) in [("--sigma-m", args.sigma_m), ("--sigma-h", args.sigma_h)] {
        if !v.is_finite() || v < 0.0 {
            return Err(InvalidInput(format!("{name} {v}: must be finite and >= 0")).into());
        }
    }
    let h = match &args.hessian {
        Some(values) => hessian_matrix(values, args.dim)?,
        None => {
            let mut h = Mat3::zeros();
            for i in 0..args.dim {
                h[(i, i)] = 1.0;
            }
            h
        }
    };
    let f = vbap_math::optimal::optimal_formation(
        args.n,
        args.dim,
        &h,
        args.sigma_h,
        args.sigma_m,
        args.seed,
    )
    .map_err(|e| InvalidInput(format!("optimal formation: {e}")))?;
    let d = args.dim;
    let positions: Vec<Vec<f64>> = f
        .positions
        .iter()
        .map(|p| p.iter().take(d).copied().collect())
        .collect();
    let moments: Vec<Vec<f64>> = (0..d)
        .map(|i| (0..d).map(|j| f.second_moments[(i, j)]).collect())
        .collect();
    if args.json {
        let out = serde_json::json!({ "g": f.g, "radius": f.radius, "positions": positions, "second_moments": moments });
        println!("{}", serde_json::to_string(&out)?);
    } else {
        println!(
            "N = {}, dim = {}, sigma_M = {}, sigma_H = {}",
            args.n, d, args.sigma_m, args.sigma_h
        );
        println!("g = {:.6}", f.g);
        println!("radius = {:.6}", f.radius);
        for (i, p) in positions.iter().enumerate() {
            println!(
                "p{i} = {:?}",
                p.iter()
                    .map(|v| (v * 1e6).round() / 1e6)
                    .collect::<Vec<_>>()
            );
        }
        println!("second moments = {moments:?}");
    }
    Ok(EXIT_OK)
}
