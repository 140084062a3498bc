//! Warnings for people: identical warnings that differ only by pose, file or numbers
//! are said once per campaign, with how many records and poses they concern and the
//! range of their numbers (`--verbose` prints every one; `--json` keeps the full list).

use std::collections::BTreeSet;
use std::path::Path;

/// Stands for the pose inside a warning's text (`... at pose (X, Y, Z) m, ...`).
const POSE_MARK: &str = "pose (\u{0}) m";

/// One warning split into where it applies and what it says.
#[derive(Debug)]
struct Parsed<'a> {
    pose: Option<&'a str>,
    file: Option<&'a str>,
    /// Text between the numbers (one more than `nums`); a pose inside the text is
    /// [`POSE_MARK`].
    text: Vec<String>,
    /// The numbers as written, with their values.
    nums: Vec<(String, f64)>,
}

/// Strips a leading `pose (X, Y, Z) m: ` and a leading `FILE: ` (an existing file or a
/// data file name), marks a pose inside the rest and splits it at its numbers.
fn parse(w: &str) -> Parsed<'_> {
    let mut rest = w;
    let mut pose = None;
    if rest.starts_with("pose (") {
        if let Some(i) = rest.find(") m: ") {
            pose = Some(&rest[..i + 3]);
            rest = &rest[i + 5..];
        }
    }
    let mut file = None;
    if let Some(i) = rest.find(": ") {
        let head = &rest[..i];
        let data_name = [".csv", ".uff", ".unv", ".txt"]
            .iter()
            .any(|e| head.to_ascii_lowercase().ends_with(e));
        if data_name || Path::new(head).is_file() {
            file = Some(head);
            rest = &rest[i + 2..];
        }
    }
    let mut body = rest.to_string();
    if pose.is_none() {
        if let Some(i) = rest.find("pose (") {
            if let Some(j) = rest[i..].find(") m") {
                pose = Some(&rest[i..i + j + 3]);
                body = format!("{}{POSE_MARK}{}", &rest[..i], &rest[i + j + 3..]);
            }
        }
    }
    let (text, nums) = split_numbers(&body);
    Parsed {
        pose,
        file,
        text: text.into_iter().map(str::to_string).collect(),
        nums: nums.into_iter().map(|(t, v)| (t.to_string(), v)).collect(),
    }
}

/// Splits `s` at its decimal numbers (`12`, `3.5`, `1e-3`, `-20.4`: a minus sign belongs to
/// the number unless it follows a digit, a letter or a bracket, as in the range `42-3432`).
fn split_numbers(s: &str) -> (Vec<&str>, Vec<(&str, f64)>) {
    let b = s.as_bytes();
    let (mut text, mut nums) = (Vec::new(), Vec::new());
    let (mut start, mut i) = (0, 0);
    while i < b.len() {
        let signed = b[i] == b'-'
            && i + 1 < b.len()
            && b[i + 1].is_ascii_digit()
            && (i == 0 || !(b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b')'));
        if b[i].is_ascii_alphabetic() || b[i] == b'_' {
            // a word, digits in it included (`xx2`, `h1`, `g04_x`)
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
                i += 1;
            }
        } else if b[i].is_ascii_digit() || signed {
            let n0 = i;
            if signed {
                i += 1;
            }
            while i < b.len() && b[i].is_ascii_digit() {
                i += 1;
            }
            if i + 1 < b.len() && b[i] == b'.' && b[i + 1].is_ascii_digit() {
                i += 1;
                while i < b.len() && b[i].is_ascii_digit() {
                    i += 1;
                }
            }
            if i + 1 < b.len() && (b[i] == b'e' || b[i] == b'E') {
                let mut j = i + 1;
                if j < b.len() && (b[j] == b'-' || b[j] == b'+') {
                    j += 1;
                }
                if j < b.len() && b[j].is_ascii_digit() {
                    while j < b.len() && b[j].is_ascii_digit() {
                        j += 1;
                    }
                    i = j;
                }
            }
            let tok = &s[n0..i];
            if let Ok(v) = tok.parse::<f64>() {
                text.push(&s[start..n0]);
                nums.push((tok, v));
                start = i;
            }
        } else {
            i += 1;
        }
    }
    text.push(&s[start..]);
    (text, nums)
}

/// A group of warnings with the same text around their numbers.
struct Group<'a> {
    first: Parsed<'a>,
    /// Lowest and highest number at each place, as written.
    lo: Vec<(String, f64)>,
    hi: Vec<(String, f64)>,
    poses: BTreeSet<&'a str>,
    files: BTreeSet<&'a str>,
    count: usize,
    /// The original text of the first member (printed alone when the group has one).
    original: &'a str,
}

/// The lines to print for `warnings`: each one as it is when `verbose` or when no two
/// share a text; otherwise one line per group, in order of first appearance, then a
/// line saying how to see them all.
pub fn summarise(warnings: &[String], verbose: bool) -> Vec<String> {
    if verbose {
        return warnings.iter().map(|w| format!("warning: {w}")).collect();
    }
    let mut groups: Vec<Group<'_>> = Vec::new();
    for w in warnings {
        let p = parse(w);
        let pos = groups
            .iter()
            .position(|g| g.first.text == p.text && g.first.nums.len() == p.nums.len());
        match pos {
            Some(k) => {
                let g = &mut groups[k];
                for (j, (tok, v)) in p.nums.into_iter().enumerate() {
                    if v < g.lo[j].1 {
                        g.lo[j] = (tok.clone(), v);
                    }
                    if v > g.hi[j].1 {
                        g.hi[j] = (tok, v);
                    }
                }
                g.poses.extend(p.pose);
                g.files.extend(p.file);
                g.count += 1;
            }
            None => groups.push(Group {
                lo: p.nums.clone(),
                hi: p.nums.clone(),
                poses: p.pose.into_iter().collect(),
                files: p.file.into_iter().collect(),
                count: 1,
                original: w,
                first: p,
            }),
        }
    }
    if groups.len() == warnings.len() {
        return warnings.iter().map(|w| format!("warning: {w}")).collect();
    }
    let mut lines: Vec<String> = groups.iter().map(group_line).collect();
    lines.push(format!(
        "({} said in {}; --verbose prints each)",
        plural(warnings.len(), "warning", "warnings"),
        plural(groups.len(), "line", "lines")
    ));
    lines
}

fn plural(n: usize, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

/// True when the text between two numbers makes them a range (`3..5`, `42-3432`).
fn range_sign(t: &str) -> bool {
    t == "-" || t == ".."
}

fn group_line(g: &Group<'_>) -> String {
    if g.count == 1 {
        return format!("warning: {}", g.original);
    }
    let text = &g.first.text;
    let mut msg = String::new();
    for (j, t) in text.iter().enumerate() {
        msg.push_str(t);
        if j < g.lo.len() {
            let (lo, hi) = (&g.lo[j], &g.hi[j]);
            if lo.1 == hi.1 {
                msg.push_str(&lo.0);
            } else if (j > 0 && range_sign(t)) || range_sign(&text[j + 1]) {
                // one end of a range `a..b`: bracket its spread
                msg.push_str(&format!("({}–{})", lo.0, hi.0));
            } else if lo.1 < 0.0 {
                // `-20.4–73.3` reads as a subtraction: spell the range out
                msg.push_str(&format!("{} to {}", lo.0, hi.0));
            } else {
                msg.push_str(&format!("{}–{}", lo.0, hi.0));
            }
        }
    }
    let poses = plural(g.poses.len(), "pose", "poses");
    if msg.contains(POSE_MARK) {
        // the pose is part of the sentence: name how many there
        let at = match g.poses.iter().next() {
            Some(p) if g.poses.len() == 1 => p.to_string(),
            _ => poses.clone(),
        };
        msg = msg.replace(POSE_MARK, &at);
    }
    let in_sentence = g.first.text.iter().any(|t| t.contains(POSE_MARK));
    if g.files.is_empty() && in_sentence && g.count == g.poses.len() {
        // once per pose, and the sentence names the poses: said as it is
        return format!("warning: {msg}");
    }
    let scope = match (g.files.len(), g.poses.len()) {
        (0, _) if in_sentence => plural(g.count, "time", "times"),
        (0, 0) => plural(g.count, "time", "times"),
        (0, _) => format!("at {poses}"),
        (f, 0) => plural(f, "record", "records"),
        (f, _) => format!("{} at {poses}", plural(f, "record", "records")),
    };
    format!("warning: {scope}: {msg}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_warning_at_many_poses_is_said_once_with_its_range() {
        let w: Vec<String> = (0..6)
            .map(|i| {
                format!(
                    "pose (0.{i}00, 0.150, 0.050) m: g0{i}_x.csv: response y is not at rest before {} of its hits (up to {} % of the response peak): leave more time",
                    i % 3 + 1,
                    20 + i
                )
            })
            .chain(["channel xy: coherence below 0.8 on 64 % of the lines".to_string()])
            .collect();
        let lines = summarise(&w, false);
        assert_eq!(lines.len(), 3, "{lines:#?}");
        assert_eq!(
            lines[0],
            "warning: 6 records at 6 poses: response y is not at rest before 1–3 of its hits (up to 20–25 % of the response peak): leave more time"
        );
        assert_eq!(
            lines[1],
            "warning: channel xy: coherence below 0.8 on 64 % of the lines"
        );
        assert!(lines[2].contains("--verbose"), "{}", lines[2]);
        assert_eq!(summarise(&w, true).len(), 7);
    }

    #[test]
    fn distinct_warnings_are_left_alone() {
        let w = vec!["a 1".to_string(), "b 2".to_string()];
        assert_eq!(summarise(&w, false), ["warning: a 1", "warning: b 2"]);
    }

    #[test]
    fn ranges_inside_a_band_are_bracketed() {
        let w: Vec<String> = ["3432.5", "3430.1"]
            .iter()
            .map(|h| format!("pose (0, 0, {h}) m: outside 3.0..{h} Hz; unreliable"))
            .collect();
        assert_eq!(
            summarise(&w, false)[0],
            "warning: at 2 poses: outside 3.0..(3430.1–3432.5) Hz; unreliable"
        );
    }

    #[test]
    fn a_pose_inside_the_sentence_is_counted() {
        let w: Vec<String> = [("0.2", "73.0", "48"), ("0.6", "84.3", "77")]
            .iter()
            .map(|(x, f, lo)| {
                format!("POOR FIT at pose ({x}, 0.150, 0.050) m, channel yx: fits at {f} % in {lo}-3040 Hz")
            })
            .collect();
        assert_eq!(
            summarise(&w, false)[0],
            "warning: POOR FIT at 2 poses, channel yx: fits at 73.0–84.3 % in (48–77)-3040 Hz"
        );
    }

    /// Negative fits keep their sign: the range runs from the lowest to the highest value.
    #[test]
    fn negative_numbers_keep_their_sign_in_a_range() {
        let w = vec![
            "POOR FIT at pose (0.1, 0.1, 0.05) m, channel zx: fits at -0.8 % in 69-2293 Hz"
                .to_string(),
            "POOR FIT at pose (0.4, 0.1, 0.05) m, channel zx: fits at -239.9 % in 69-2293 Hz"
                .to_string(),
            "POOR FIT at pose (0.7, 0.1, 0.05) m, channel zx: fits at 12.5 % in 69-2293 Hz"
                .to_string(),
        ];
        let out = summarise(&w, false);
        assert!(
            out[0].contains("fits at -239.9 to 12.5 % in 69-2293 Hz"),
            "{out:?}"
        );
    }

    #[test]
    fn words_with_digits_are_text() {
        let (text, nums) = split_numbers("channel xx2 h1 at 12.5 Hz and 1e-3 s");
        assert_eq!(
            nums.iter().map(|n| n.0).collect::<Vec<_>>(),
            ["12.5", "1e-3"]
        );
        assert_eq!(text, ["channel xx2 h1 at ", " Hz and ", " s"]);
    }
}
