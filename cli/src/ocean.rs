//! `vbap ocean`: writes the synthetic ocean example (a CF NetCDF classic file, or NetCDF-4
//! with `--netcdf4` in a build with the `netcdf4` feature, on a lon/lat
//! grid: sea temperature with a front and eddies, u/v currents, a coast and an island as
//! land) that `deploy/missions/ocean_grid.toml` uses. The ocean itself is
//! `vbap_formats::ocean`.

use std::path::PathBuf;

use clap::Args;
use vbap_formats::ocean;

use crate::errors::InvalidInput;

/// Arguments of `vbap ocean`.
#[derive(Args, Debug)]
pub struct OceanArgs {
    /// The file to write (NetCDF classic, replaced if it exists).
    #[arg(long)]
    pub out: PathBuf,
    /// Grid size NX,NY (lon × lat nodes, each 4..=4000).
    #[arg(long, default_value = "160,150")]
    pub size: String,
    /// Seed of the eddies' positions (each within ±1 km of its place).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Write NetCDF-4 (HDF5) instead of classic (a build with the `netcdf4` feature).
    #[arg(long)]
    pub netcdf4: bool,
}

/// (nx, ny) from "NX,NY", or why not.
pub fn parse_size(s: &str) -> Result<(usize, usize), String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let [nx, ny] = parts.as_slice() else {
        return Err(format!("--size {s}: expected NX,NY (e.g. 160,150)"));
    };
    let n = |v: &str| -> Result<usize, String> {
        v.parse::<usize>()
            .ok()
            .filter(|n| (4..=4000).contains(n))
            .ok_or_else(|| format!("--size {s}: {v:?} must be a whole number from 4 to 4000"))
    };
    Ok((n(nx)?, n(ny)?))
}

/// Runs `vbap ocean`.
pub fn main(args: &OceanArgs) -> anyhow::Result<i32> {
    let (nx, ny) = parse_size(&args.size).map_err(InvalidInput)?;
    if args.netcdf4 && !ocean::NETCDF4 {
        return Err(InvalidInput(
            "--netcdf4: this vbap was built without the `netcdf4` feature (cargo build --release --workspace --bins --features vbap-mission/netcdf4)".into(),
        )
        .into());
    }
    let write = if args.netcdf4 {
        ocean::write_ocean_netcdf4
    } else {
        ocean::write_ocean
    };
    write(&args.out, nx, ny, args.seed)
        .map_err(|e| anyhow::anyhow!("{}: cannot write: {e}", args.out.display()))?;
    println!(
        "{}: synthetic ocean {nx} x {ny} (seed {}), lon {:?} lat {:?}; variables temperature, u, v, land_mask",
        args.out.display(),
        args.seed,
        ocean::LON,
        ocean::LAT
    );
    Ok(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn size_is_two_numbers_in_range() {
        assert_eq!(parse_size("160,150"), Ok((160, 150)));
        assert_eq!(parse_size(" 10 , 12 "), Ok((10, 12)));
        assert!(parse_size("3,10").unwrap_err().contains("from 4 to 4000"));
        assert!(parse_size("10").unwrap_err().contains("NX,NY"));
    }
}
