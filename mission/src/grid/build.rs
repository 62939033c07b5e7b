//! From a variable as read to a [`GridField`]: roles and units of the axes, the projection,
//! monotone and long-enough axes, the data layout, land and the optimum candidates.

use vbap_formats::cf::{self, Role, Units};
use vbap_formats::RawVar;

use super::axis::{Axis, MIN_NODES};
use super::{GridError, GridField, GridSpec, Layout};

/// One axis's values in file order, in mission units (projection aside), and whether they
/// are degrees.
struct RawAxis {
    name: String,
    values: Vec<f64>,
    units: Units,
}

fn raw_axis(var: &RawVar, k: usize, role: Role, spec: &GridSpec) -> Result<RawAxis, GridError> {
    let n = var.shape[k];
    if let Some(c) = &var.coords[k] {
        if c.values.len() != n {
            return Err(GridError::new(
                &spec.file,
                &c.name,
                format!("has {} values for a dimension of {n}", c.values.len()),
            ));
        }
        let mut units = cf::units(c, role, &spec.file)?;
        let lonlat = matches!(
            c.name.to_lowercase().as_str(),
            "lon" | "longitude" | "lat" | "latitude"
        );
        let geo = spec.geographic.unwrap_or(var.bare && lonlat);
        if geo && units == Units::Length(1.0) && c.units.is_empty() {
            units = if role == Role::X {
                Units::DegreesEast
            } else {
                Units::DegreesNorth
            };
        }
        return Ok(RawAxis {
            name: c.name.clone(),
            values: c.values.clone(),
            units,
        });
    }
    let span = |i: usize| -> Option<(f64, f64)> {
        let e = spec.extent.as_ref()?;
        Some((*e.get(2 * i)?, *e.get(2 * i + 1)?))
    };
    let which = match role {
        Role::X => span(0),
        Role::Y => span(1),
        Role::Z => span(2),
        Role::T => Some((0.0, 0.0)),
    };
    let Some((a, b)) = which.filter(|_| var.bare || role == Role::T) else {
        return Err(GridError::new(
            &spec.file,
            &var.name,
            format!(
                "dimension {:?} has no coordinate values (a .npy needs field.extent, a file its coordinate variable)",
                var.dims[k]
            ),
        ));
    };
    let step = if n > 1 { (b - a) / (n - 1) as f64 } else { 0.0 };
    let geo = spec.geographic == Some(true) && matches!(role, Role::X | Role::Y);
    Ok(RawAxis {
        name: var.dims[k].clone(),
        values: (0..n).map(|j| a + j as f64 * step).collect(),
        units: match (geo, role) {
            (true, Role::X) => Units::DegreesEast,
            (true, _) => Units::DegreesNorth,
            (_, Role::T) => Units::Time(if n > 1 { 1.0 } else { 0.0 }),
            _ => Units::Length(1.0),
        },
    })
}

/// Checks that `v` is strictly monotone; returns whether it descends.
fn monotone(spec: &GridSpec, name: &str, v: &[f64]) -> Result<bool, GridError> {
    if v.iter().any(|x| !x.is_finite()) {
        return Err(GridError::new(
            &spec.file,
            name,
            "non-monotone axis (a value is not finite)",
        ));
    }
    let up = v.windows(2).all(|w| w[1] > w[0]);
    let down = v.windows(2).all(|w| w[1] < w[0]);
    if !(up || down) {
        return Err(GridError::new(
            &spec.file,
            name,
            "non-monotone axis (coordinates must strictly increase or strictly decrease)",
        ));
    }
    Ok(down && v.len() > 1)
}

/// Reads and builds the grid of `spec`.
pub fn load(spec: &GridSpec) -> Result<GridField, GridError> {
    let var = vbap_formats::read_variable(&spec.file, spec.variable.as_deref(), &spec.names)?;
    let dims = dimensions(spec, &var)?;
    let mut axes = Vec::new();
    for (role, k) in [Role::X, Role::Y, Role::Z, Role::T].into_iter().zip(dims) {
        axes.push(match k {
            Some(k) => Some(raw_axis(&var, k, role, spec)?),
            None => None,
        });
    }
    let origin = geographic_origin(spec, &var, &mut axes)?;
    let Laid {
        layout,
        mut built,
        times,
    } = lay_out(spec, &var, &axes, dims)?;
    let mut g = GridField {
        file: spec.file.display().to_string(),
        variable: var.name.clone(),
        dim: spec.dim,
        x: built[0].take().expect("x axis"),
        y: built[1].take().expect("y axis"),
        z: built[2].take(),
        times,
        origin,
        data: super::values::Values::F64(var.data),
        layout,
        land: Vec::new(),
        best: Vec::new(),
        extrema: [0, 0],
    };
    canonical(&mut g);
    super::land::mark_and_fill(&mut g, spec.land_above)?;
    super::optimum::prepare(&mut g);
    g.data.compact();
    Ok(g)
}

/// The dimension of `var` that is each axis (x, y, z, time), x and y always found; an
/// error when the variable's rank does not fit the mission's dimension.
fn dimensions(spec: &GridSpec, var: &RawVar) -> Result<[Option<usize>; 4], GridError> {
    let roles = cf::roles(var, &spec.names, spec.dim, &spec.file)?;
    let find = |r: Role| roles.iter().position(|x| *x == r);
    let rank_err =
        |what: String| GridError::new(&spec.file, &var.name, format!("wrong rank: {what}"));
    let (Some(kx), Some(ky)) = (find(Role::X), find(Role::Y)) else {
        return Err(rank_err(format!(
            "dimensions {:?} have no x and y axis (a field needs both)",
            var.dims
        )));
    };
    let kz = find(Role::Z);
    let nz = kz.map_or(1, |k| var.shape[k]);
    if spec.dim == 2 && nz > 1 {
        return Err(rank_err(format!(
            "a 3-D variable ({nz} levels) for a 2-D mission (mission.dim = 3, or a file with one level)"
        )));
    }
    if spec.dim == 3 && nz < MIN_NODES {
        return Err(rank_err(format!(
            "a 3-D mission needs a vertical axis of at least {MIN_NODES} levels (the variable has {nz})"
        )));
    }
    Ok([Some(kx), Some(ky), kz, find(Role::T)])
}

/// When x/y are lon/lat degrees: projects them about the origin and returns it (None for
/// a grid in length units); an error when the mission says geographic and they are not.
fn geographic_origin(
    spec: &GridSpec,
    var: &RawVar,
    axes: &mut [Option<RawAxis>],
) -> Result<Option<[f64; 2]>, GridError> {
    let (lon, lat) = (&axes[0], &axes[1]);
    let geographic = matches!(
        (lon.as_ref().map(|a| a.units), lat.as_ref().map(|a| a.units)),
        (Some(Units::DegreesEast), Some(Units::DegreesNorth))
    );
    if spec.geographic == Some(true) && !geographic {
        return Err(GridError::new(
            &spec.file,
            &var.name,
            "field.geographic = true but the x/y coordinates are not lon/lat degrees",
        ));
    }
    if geographic {
        return Ok(Some(project(spec, axes)?));
    }
    Ok(None)
}

/// The axes of a grid laid out ascending: where each node's value is in the file's order.
struct Laid {
    layout: Layout,
    /// x, y, z (3-D) in mission length units, ascending; None for z in 2-D and for time.
    built: Vec<Option<Axis>>,
    /// Times, s from the first, ascending (one entry for a steady field).
    times: Vec<f64>,
}

/// Lays out `axes` (x, y, z, time; in dimensions `dims` of `var`): each strictly monotone,
/// flipped to ascend (the layout steps back through a descending one), scaled to mission
/// units, long enough for the cubic interpolation.
fn lay_out(
    spec: &GridSpec,
    var: &RawVar,
    axes: &[Option<RawAxis>],
    dims: [Option<usize>; 4],
) -> Result<Laid, GridError> {
    let mut layout = Layout::default();
    let strides = row_major(&var.shape);
    let mut built: Vec<Option<Axis>> = Vec::new();
    let mut times = vec![0.0];
    for (r, a) in axes.iter().enumerate() {
        let (Some(a), Some(k)) = (a, dims[r]) else {
            built.push(None);
            continue;
        };
        let descending = monotone(spec, &a.name, &a.values)?;
        let n = a.values.len();
        let stride = strides[k] as isize;
        layout.step[r] = if descending { -stride } else { stride };
        layout.first[r] = if descending {
            (n as isize - 1) * stride
        } else {
            0
        };
        let mut v: Vec<f64> = a.values.clone();
        if descending {
            v.reverse();
        }
        if r == 3 {
            let f = match a.units {
                Units::Time(f) => f,
                _ => 1.0,
            };
            times = v.iter().map(|x| (x - v[0]) * f).collect();
            built.push(None);
            continue;
        }
        if let Units::Length(f) = a.units {
            v.iter_mut().for_each(|x| *x *= f);
        }
        if (r < 2 || spec.dim == 3) && n < MIN_NODES {
            return Err(GridError::new(
                &spec.file,
                &a.name,
                format!("axis has {n} points; the cubic interpolation needs at least {MIN_NODES}"),
            ));
        }
        built.push((r < 2 || spec.dim == 3).then(|| Axis::new(v)));
    }
    Ok(Laid {
        layout,
        built,
        times,
    })
}

/// Reorders the values, if need be, so that x varies fastest, then y, z and time, every axis
/// ascending (node (jx, jy, jz, jt) at jx + nx (jy + ny (jz + nz jt))): the four nodes of an
/// interpolation stencil along x are then adjacent in memory, read as one slice.
fn canonical(g: &mut GridField) {
    let (nx, ny) = (g.x.len(), g.y.len());
    let nz = g.z.as_ref().map_or(1, |z| z.len());
    let want = Layout {
        first: [0; 4],
        step: [1, nx as isize, (nx * ny) as isize, (nx * ny * nz) as isize],
    };
    let n = nx * ny * nz * g.times.len();
    if g.layout == want && g.data.len() == n {
        return;
    }
    let mut data = Vec::with_capacity(n);
    for jt in 0..g.times.len() {
        for jz in 0..nz {
            for jy in 0..ny {
                let row = g.node_index(0, jy, jz, jt) as isize;
                let step = g.layout.step[0];
                data.extend((0..nx as isize).map(|jx| g.data.get((row + jx * step) as usize)));
            }
        }
    }
    g.data = super::values::Values::F64(data);
    g.layout = want;
}

fn row_major(shape: &[usize]) -> Vec<usize> {
    let mut s = vec![1; shape.len()];
    for k in (0..shape.len().saturating_sub(1)).rev() {
        s[k] = s[k + 1] * shape[k + 1];
    }
    s
}

/// Projects the lon/lat axes about the origin (given, or the grid centre); returns it.
fn project(spec: &GridSpec, axes: &mut [Option<RawAxis>]) -> Result<[f64; 2], GridError> {
    let mid = |v: &[f64]| (v[0] + v[v.len() - 1]) / 2.0;
    let lon = axes[0].as_ref().expect("x");
    let lat = axes[1].as_ref().expect("y");
    if lat.values.iter().any(|l| !(-90.0..=90.0).contains(l)) {
        return Err(GridError::new(
            &spec.file,
            &lat.name,
            "latitude outside −90..90",
        ));
    }
    // The centre of the longitudes taken as a contiguous run (0..360 files across 180° too).
    let lon0 = spec.origin.map_or_else(
        || {
            let first = lon.values[0];
            let wrapped: Vec<f64> = lon
                .values
                .iter()
                .map(|l| first + (l - first + 180.0).rem_euclid(360.0) - 180.0)
                .collect();
            mid(&wrapped)
        },
        |o| o[0],
    );
    let lat0 = spec.origin.map_or_else(|| mid(&lat.values), |o| o[1]);
    let xs = lon
        .values
        .iter()
        .map(|l| vbap_math::gridmath::equirectangular(*l, lat0, lon0, lat0).0)
        .collect();
    let ys = lat
        .values
        .iter()
        .map(|l| vbap_math::gridmath::equirectangular(lon0, *l, lon0, lat0).1)
        .collect();
    if let Some(a) = axes[0].as_mut() {
        a.values = xs;
        a.units = Units::Length(1.0);
    }
    if let Some(a) = axes[1].as_mut() {
        a.values = ys;
        a.units = Units::Length(1.0);
    }
    Ok([lon0, lat0])
}
