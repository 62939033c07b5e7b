//! Numbers, vectors and matrices as TOML shows them, for error messages and the resolved
//! mission.

/// Formats a number the way TOML would show it (shortest form, exponent for tiny or huge
/// numbers).
pub(super) fn num(x: f64) -> String {
    crate::rundir::Num(x).to_string()
}

/// Formats a vector as a TOML array.
pub(super) fn vec_str(v: &[f64]) -> String {
    let items: Vec<String> = v.iter().map(|x| num(*x)).collect();
    format!("[{}]", items.join(", "))
}

/// Formats a matrix as a TOML array of arrays.
pub(super) fn mat_str(m: &[Vec<f64>]) -> String {
    let rows: Vec<String> = m.iter().map(|r| vec_str(r)).collect();
    format!("[{}]", rows.join(", "))
}

/// `text` (TOML as the `toml` crate writes it) with every float outside 1e-4 ≤ |x| < 1e16
/// rewritten in the exponent form of [`crate::rundir::Num`] (`1e-300`, not 300 digits):
/// the same number, still a TOML float. Strings and comments are left alone.
pub(super) fn short_floats(text: &str) -> String {
    let chars: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut token = String::new();
    let flush = |token: &mut String, out: &mut String| {
        let short = (token.contains('.') || token.contains('e'))
            .then(|| token.parse::<f64>().ok())
            .flatten()
            .map(|x| crate::rundir::Num(x).to_string())
            .filter(|s| s.contains('e') && s.len() < token.len());
        out.push_str(short.as_deref().unwrap_or(token));
        token.clear();
    };
    let mut i = 0;
    while i < chars.len() {
        let ch = chars[i];
        if ch.is_ascii_alphanumeric() || matches!(ch, '.' | '+' | '-' | '_') {
            token.push(ch);
            i += 1;
            continue;
        }
        flush(&mut token, &mut out);
        // A string (single or triple quotes, the basic ones with \ escapes) or a comment is
        // copied as it is.
        let end = match ch {
            '"' | '\'' => {
                let triple = chars.get(i + 1) == Some(&ch) && chars.get(i + 2) == Some(&ch);
                let open = if triple { 3 } else { 1 };
                let mut j = i + open;
                loop {
                    match chars.get(j) {
                        None => break chars.len(),
                        Some('\\') if ch == '"' => j += 2,
                        Some(c)
                            if *c == ch && (!triple || chars[j..].starts_with(&[ch, ch, ch])) =>
                        {
                            break j + open;
                        }
                        _ => j += 1,
                    }
                }
            }
            '#' => chars[i..]
                .iter()
                .position(|c| *c == '\n')
                .map_or(chars.len(), |n| i + n),
            _ => i + 1,
        };
        let end = end.min(chars.len());
        out.extend(&chars[i..end]);
        i = end;
    }
    flush(&mut token, &mut out);
    out
}
