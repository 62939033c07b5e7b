//! A variable as read from a file, whatever the format: its dimensions, values and the
//! coordinate variable of each dimension. The readers ([`crate::read`], and `nc4.rs`) make
//! it; [`crate::cf`] tells its axes from it.

/// A coordinate variable: its values and the CF attributes that tell which axis it is.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Coord {
    /// Variable name.
    pub name: String,
    /// Values in file order.
    pub values: Vec<f64>,
    /// `units` (empty if absent).
    pub units: String,
    /// `standard_name` (empty if absent).
    pub standard_name: String,
    /// `axis` (`X`, `Y`, `Z`, `T`; empty if absent).
    pub axis: String,
    /// `positive` (`up` / `down`; empty if absent).
    pub positive: String,
}

impl Coord {
    /// The coordinate variable `name` of a self-describing file, its `axis` upper-cased and
    /// `positive` lower-cased as CF compares them.
    pub(crate) fn of_file(
        name: String,
        values: Vec<f64>,
        units: String,
        standard_name: String,
        axis: &str,
        positive: &str,
    ) -> Self {
        Self {
            name,
            values,
            units,
            standard_name,
            axis: axis.to_uppercase(),
            positive: positive.to_lowercase(),
        }
    }
}

/// A variable as read: its dimensions (slowest first), values (missing data = NaN) and the
/// coordinate variable of each dimension, if the file has one.
#[derive(Clone, Debug, Default)]
pub struct RawVar {
    /// Variable name.
    pub name: String,
    /// Dimension names, slowest first.
    pub dims: Vec<String>,
    /// Dimension lengths, slowest first.
    pub shape: Vec<usize>,
    /// Row-major values; `_FillValue`, `missing_value` and NaN are NaN.
    pub data: Vec<f64>,
    /// The coordinate variable of each dimension (same name as the dimension), if any.
    pub coords: Vec<Option<Coord>>,
    /// Whether the file says nothing about its axes (NumPy): the mission must.
    pub bare: bool,
}

impl RawVar {
    /// Variable `name` of a self-describing file (NetCDF): packed values already unpacked
    /// by [`unpack`], the file's coordinate variables.
    pub(crate) fn of_file(
        name: String,
        dims: Vec<String>,
        shape: Vec<usize>,
        data: Vec<f64>,
        coords: Vec<Option<Coord>>,
    ) -> Self {
        Self {
            name,
            dims,
            shape,
            data,
            coords,
            bare: false,
        }
    }
}
