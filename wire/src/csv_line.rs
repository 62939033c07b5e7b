//! The text of numbers in a run's CSV files, and the rows themselves, written without
//! `core::fmt`: the coordinator writes a row per vehicle per tick, and formatting floats was
//! the largest single cost of `vbap sim` (about a quarter of its time at N = 16).
//!
//! [`Num`] is the one spelling of an `f64` in every CSV of a run: the shortest text that
//! reads back to the same number. [`push_num`] writes exactly the bytes of `Num`'s
//! `Display` — checked against it over millions of values in the tests — but takes the
//! fast shortest-digits algorithm of the `zmij` crate where it provably gives the digits of
//! `std`, and `std` itself elsewhere:
//!
//! - integers, zero and non-finite values (rare in the files, `std` spells them `1`, not
//!   `1.0`);
//! - values whose exact binary value has at most 18 significant decimal digits: only these
//!   can lie exactly halfway between two shortest candidates, where `zmij` rounds the last
//!   digit to even and `std` does not always (e.g. 834912881234988.25);
//! - values where the two would choose different layouts (plain decimals against the
//!   exponent form, at 1e-5 ≤ |x| < 1e-4).

/// An `f64` written in the shortest form that reads back to the same number: plain decimals
/// (`{}`) for 1e-4 ≤ |x| < 1e16 and zero, the exponent form (`{:e}`, e.g. `1e-25`) outside,
/// where plain decimals would run to hundreds of digits (`{}` writes 1e-300 in full). Every
/// CSV writer of a run uses it, in `vbap sim` and `vbap run` alike.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Num(pub f64);

impl Num {
    /// True when the exponent form is this number's spelling.
    fn exponent_form(self) -> bool {
        let a = self.0.abs();
        self.0 != 0.0 && a.is_finite() && !(1e-4..1e16).contains(&a)
    }
}

impl std::fmt::Display for Num {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if let Some(text) = zmij_text(self.0, &mut zmij::Buffer::new()) {
            return f.write_str(text);
        }
        std_text(*self, f)
    }
}

/// `Num`'s spelling by `std`'s formatting (the reference).
fn std_text(x: Num, f: &mut impl std::fmt::Write) -> std::fmt::Result {
    if x.exponent_form() {
        write!(f, "{:e}", x.0)
    } else {
        write!(f, "{}", x.0)
    }
}

/// `Num(x)`'s text from `zmij`, or None where it might differ from `std`'s (see the module
/// docs).
fn zmij_text(x: f64, buf: &mut zmij::Buffer) -> Option<&str> {
    if !x.is_finite() || x.fract() == 0.0 || may_tie(x) {
        return None;
    }
    let text = buf.format_finite(x);
    (text.contains('e') == Num(x).exponent_form()).then_some(text)
}

/// True when the exact value of the finite non-integer `x` has at most 18 significant
/// decimal digits. Then (and only then) it can lie halfway between two shortest decimal
/// candidates of up to 17 digits, where round-half-even and `std` may part.
fn may_tie(x: f64) -> bool {
    let bits = x.to_bits();
    let biased = ((bits >> 52) & 0x7ff) as i32;
    let fraction = bits & ((1u64 << 52) - 1);
    let (mantissa, exp2) = if biased == 0 {
        (fraction, -1074)
    } else {
        (fraction | (1u64 << 52), biased - 1075)
    };
    // x = odd · 2^-k with k > 0 (x is no integer): its exact decimal is odd · 5^k / 10^k,
    // whose significant digits are those of odd · 5^k.
    let zeros = mantissa.trailing_zeros() as i32;
    let odd = u128::from(mantissa >> zeros);
    let k = -(exp2 + zeros);
    // 5^27 > 10^18: beyond that the digits of odd · 5^k exceed 18 whatever odd is.
    k <= 27 && odd * 5u128.pow(k as u32) < 1_000_000_000_000_000_000
}

/// Appends `Num(x)`'s text to `out`.
pub fn push_num(out: &mut String, x: f64) {
    if let Some(n) = small_integer(x) {
        if x.is_sign_negative() {
            out.push('-');
        }
        out.push_str(itoa::Buffer::new().format(n));
        return;
    }
    match zmij_text(x, &mut zmij::Buffer::new()) {
        Some(text) => out.push_str(text),
        None => std_text(Num(x), out).expect("writing to a String cannot fail"),
    }
}

/// `|x|` when `x` is an integer below 2^53 in magnitude (zero and −0 included). `std`
/// spells such a value as the decimal digits of that integer (a sign first when
/// negative, `-0` for −0, no `.0`): below 2^53 every integer is a double and the shortest
/// digits that read back to `x` are its own (any other candidate with as few digits is
/// another integer, at least 1 away, beyond the half-ulp ≤ ½ that reads back to `x`).
/// Such values are common in the files (times of whole seconds, zero ages), and `std`'s
/// formatting of them is slow.
fn small_integer(x: f64) -> Option<u64> {
    const LIMIT: f64 = (1u64 << 53) as f64;
    let a = x.abs();
    (a < LIMIT && a.fract() == 0.0).then_some(a as u64)
}

/// The text of groups of `K` number cells remembered by the bits of their numbers, the
/// last two groups per key (a small index: a vehicle's id; keys from [`Memo::MAX_KEY`] on
/// are not remembered), for numbers written again and again: a tick's time on every row of
/// the tick, a vehicle's state on its rows of `planner_inputs.csv` and of `vehicles.csv`
/// (the same report in lockstep on ideal links; a submerged glider's last report, on its
/// `member` row tick after tick, beside its true state). The text is [`push_num`]'s, a
/// function of the bits alone, so a remembered group writes the same bytes as the numbers
/// would.
pub struct Memo<const K: usize> {
    /// Per key: two groups, and which of them was used last.
    groups: Vec<([Group<K>; 2], usize)>,
}

/// The bits of `K` numbers and their text (none yet).
type Group<const K: usize> = Option<([u64; K], String)>;

impl<const K: usize> Default for Memo<K> {
    fn default() -> Self {
        Self { groups: Vec::new() }
    }
}

impl<const K: usize> Memo<K> {
    /// Keys from this one on are written without remembering.
    pub const MAX_KEY: usize = 1 << 20;
}

/// One CSV row under construction: cells appended with their separating commas, then
/// handed to a writer whole by [`Line::finish`]. Reuse one `Line` for every row.
#[derive(Default)]
pub struct Line {
    text: String,
    cells: usize,
}

impl Line {
    fn comma(&mut self) {
        if self.cells > 0 {
            self.text.push(',');
        }
        self.cells += 1;
    }
    /// A number cell ([`Num`]).
    pub fn num(&mut self, x: f64) -> &mut Self {
        self.comma();
        push_num(&mut self.text, x);
        self
    }
    /// A number cell, or an empty one for none.
    pub fn opt(&mut self, x: Option<f64>) -> &mut Self {
        self.comma();
        if let Some(x) = x {
            push_num(&mut self.text, x);
        }
        self
    }
    /// Three number cells (x, y, z).
    pub fn vec3(&mut self, v: &vbap_math::Vec3) -> &mut Self {
        self.num(v.x).num(v.y).num(v.z)
    }
    /// `K` number cells, as [`Line::num`] of each, their text taken from `memo`'s group
    /// `key` when it holds the same numbers (bit for bit), and kept there otherwise.
    pub fn nums_memo<const K: usize>(
        &mut self,
        xs: &[f64; K],
        key: usize,
        memo: &mut Memo<K>,
    ) -> &mut Self {
        if key >= Memo::<K>::MAX_KEY {
            for &x in xs {
                self.num(x);
            }
            return self;
        }
        if memo.groups.len() <= key {
            memo.groups.resize_with(key + 1, || ([None, None], 0));
        }
        let bits = xs.map(f64::to_bits);
        let (pair, last) = &mut memo.groups[key];
        let hit = pair
            .iter()
            .position(|g| matches!(g, Some((b, _)) if *b == bits));
        // On a miss, the group not used last makes way.
        let at = hit.unwrap_or(1 - *last);
        *last = at;
        let group = &mut pair[at];
        if hit.is_none() {
            let (b, text) = group.get_or_insert_with(|| (bits, String::new()));
            *b = bits;
            text.clear();
            for (i, &x) in xs.iter().enumerate() {
                if i > 0 {
                    text.push(',');
                }
                push_num(text, x);
            }
        }
        let text = group.as_ref().map_or("", |(_, text)| text.as_str());
        if K > 0 {
            self.comma();
            self.text.push_str(text);
            self.cells += K - 1;
        }
        self
    }
    /// An integer cell.
    pub fn int(&mut self, n: impl itoa::Integer) -> &mut Self {
        self.comma();
        self.text.push_str(itoa::Buffer::new().format(n));
        self
    }
    /// A text cell, as is (the caller keeps commas and line breaks out of it).
    pub fn text(&mut self, s: &str) -> &mut Self {
        self.comma();
        self.text.push_str(s);
        self
    }
    /// Writes the row and its line break to `out` and empties the line for the next row.
    pub fn finish(&mut self, out: &mut impl std::io::Write) -> std::io::Result<()> {
        self.text.push('\n');
        let written = out.write_all(self.text.as_bytes());
        self.text.clear();
        self.cells = 0;
        written
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reference(x: f64) -> String {
        let mut s = String::new();
        std_text(Num(x), &mut s).unwrap();
        s
    }

    fn check(x: f64) {
        let mut fast = String::new();
        push_num(&mut fast, x);
        assert_eq!(fast, reference(x), "{x:e} (bits {:#x})", x.to_bits());
        assert_eq!(Num(x).to_string(), fast);
    }

    /// xorshift64: reproducible values without a dependency.
    fn values(seed: u64) -> impl Iterator<Item = u64> {
        let mut s = seed;
        std::iter::repeat_with(move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        })
    }

    #[test]
    fn every_bit_pattern_kind_spells_as_std() {
        for bits in values(0x9e37_79b9_7f4a_7c15).take(400_000) {
            check(f64::from_bits(bits));
        }
    }

    #[test]
    fn values_of_every_decade_spell_as_std() {
        let mut r = values(0x2545_f491_4f6c_dd1d);
        for _ in 0..400_000 {
            let unit = r.next().unwrap() as f64 / u64::MAX as f64 - 0.5;
            let decade = (r.next().unwrap() % 48) as i32 - 24;
            check(unit * 10f64.powi(decade));
        }
    }

    #[test]
    fn short_binary_fractions_and_halfway_cases_spell_as_std() {
        // Values whose exact decimals are short, where a shortest candidate can tie:
        // odd · 2^-k for small odd and every k, and the tie found by a random search.
        for k in 1..80 {
            for odd in [
                1u64,
                3,
                5,
                7,
                9,
                11,
                13,
                1 << 17 | 1,
                (1 << 52) + 1,
                (1 << 53) - 1,
            ] {
                let x = odd as f64 * 2f64.powi(-k);
                check(x);
                check(-x);
                check(1.0 + x);
            }
        }
        // Exactly halfway cases (the values are exact in binary).
        check(834_912_881_234_988.0 + 0.25);
        check(-(231_128_875_322_666.0 + 0.625));
        check(1.0 + 2f64.powi(-17));
    }

    #[test]
    fn special_values_and_the_layout_boundaries_spell_as_std() {
        for x in [
            0.0,
            -0.0,
            1.0,
            -3.0,
            123.0,
            1e-4,
            9.999999999999999e-5,
            5e-5,
            1e-5,
            1e16,
            9.999999999999998e15,
            1e22,
            5e-324,
            f64::MIN_POSITIVE,
            f64::MAX,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            0.1,
            2.5e-7,
        ] {
            check(x);
        }
    }

    #[test]
    fn integers_spell_as_std() {
        let limit = (1u64 << 53) as f64;
        for x in [
            0.0,
            -0.0,
            1.0,
            -1.0,
            10.0,
            100.0,
            1e15,
            -1e15,
            limit - 1.0,
            -(limit - 1.0),
            limit,
            limit + 2.0,
            9_007_199_254_740_994.0,
            9.999_999_999_999_998e15,
            1e16,
            123_456_789.0,
            86_400.0,
        ] {
            check(x);
        }
        let mut r = values(0x1234_5678_9abc_def1);
        for _ in 0..200_000 {
            let bits = r.next().unwrap();
            let scale = 1u64 << (bits % 54);
            let n = (r.next().unwrap() % scale) as f64;
            check(n);
            check(-n);
            check(n * 10f64.powi((bits % 5) as i32));
        }
    }

    #[test]
    fn remembered_groups_write_the_same_bytes() {
        let mut memo = Memo::<3>::default();
        let mut one = Memo::<1>::default();
        let mut a = Line::default();
        let mut b = Line::default();
        let (mut out_a, mut out_b) = (Vec::new(), Vec::new());
        let groups = [
            [0.5, -0.0, 1e-7],
            [0.5, -0.0, 1e-7],
            [0.5, 0.0, 1e-7],
            [f64::NAN, 3.0, 0.1 + 0.2],
            [0.5, 0.0, 1e-7],
            [f64::NAN, 3.0, 0.1 + 0.2],
            [7.0, 8.0, 9.0],
            [0.5, 0.0, 1e-7],
            [7.0, 8.0, 9.0],
            [0.25, 8.0, 9.0],
        ];
        for (row, xs) in groups.iter().enumerate() {
            for key in [0, 2, Memo::<3>::MAX_KEY] {
                let t = row as f64 * 0.05;
                a.num(t).int(key).num(xs[0]).num(xs[1]).num(xs[2]).text("x");
                a.finish(&mut out_a).unwrap();
                b.nums_memo(&[t], 0, &mut one)
                    .int(key)
                    .nums_memo(xs, key, &mut memo)
                    .text("x");
                b.finish(&mut out_b).unwrap();
            }
        }
        assert_eq!(
            String::from_utf8(out_b).unwrap(),
            String::from_utf8(out_a).unwrap()
        );
        let mut c = Line::default();
        let mut out = Vec::new();
        c.nums_memo(&[1.5, 2.0], 1, &mut Memo::default())
            .finish(&mut out)
            .unwrap();
        assert_eq!(out, b"1.5,2\n");
    }

    #[test]
    fn a_line_writes_its_cells_comma_separated() {
        let mut line = Line::default();
        let mut out = Vec::new();
        line.num(0.5)
            .int(7u64)
            .text("ok")
            .opt(None)
            .opt(Some(1e-7))
            .finish(&mut out)
            .unwrap();
        line.int(1u32).finish(&mut out).unwrap();
        assert_eq!(String::from_utf8(out).unwrap(), "0.5,7,ok,,1e-7\n1\n");
    }
}
