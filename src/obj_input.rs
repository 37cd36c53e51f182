//! OBJ and MTL files as exporters and scene archives write them, made into what tobj reads.
//!
//! - File names (`mtllib`, `map_Kd`) are found the way their authors meant them: Windows separators,
//!   quotes, another letter case than the file on disk, a Windows absolute path (its file name beside
//!   the file that names it), a texture beside its .mtl rather than its OBJ.
//! - Text is decoded whatever its encoding marks: a byte-order mark is dropped (UTF-8 and UTF-16),
//!   and a file that is not UTF-8 is read as Latin-1 (accented comments from older exporters), named.
//! - Statements are normalised without moving a line (errors keep the file's line numbers): lone
//!   carriage returns end lines, tabs separate words, a `\` at a line's end joins the next line.
//! - What tobj would reject as a whole .mtl (every material then lost) is read per statement: the
//!   colour forms `Kd r` (g = b = r) and `Kd xyz x y z` (CIE XYZ), values after a colour's three,
//!   `d -halo v`, `Tr`, `illum` written as a float; what cannot be read (`Kd spectral`, an unreadable
//!   `Ka`) is dropped and named. Malformed numbers the renderer reads (Kd, Ks, Ns, Ni, d) are errors
//!   naming the line, as the values the loader checks are.
//!
//! Every change that alters what a user sees is said in a note (a loader warning).
use std::path::{Component, Path, PathBuf};

/// The file `name` (as an OBJ or .mtl writes it) in the first of `dirs` that holds it: as written
/// (`\` read as `/`, surrounding quotes dropped), then matching each path component without regard
/// to letter case, then the file name alone in each folder. `None` where nothing matches.
pub fn find_file(dirs: &[&Path], name: &str) -> Option<PathBuf> {
    let name = name.trim().trim_matches('"').trim_matches('\'').trim();
    if name.is_empty() {
        return None;
    }
    let written = PathBuf::from(name.replace('\\', "/"));
    let file_name = written.file_name().map(PathBuf::from);
    let tries = std::iter::once(&written).chain(file_name.as_ref());
    for rel in tries {
        for dir in dirs {
            let exact = dir.join(rel);
            if exact.is_file() {
                return Some(exact);
            }
            if let Some(found) = case_insensitive(dir, rel) {
                return Some(found);
            }
        }
    }
    None
}

/// The folder that holds `file` (`.` for a bare file name, whose parent is empty).
pub fn folder_of(file: &Path) -> PathBuf {
    match file.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// `dir/rel` where each component of `rel` may differ from the one on disk in letter case.
fn case_insensitive(dir: &Path, rel: &Path) -> Option<PathBuf> {
    let mut at = dir.to_path_buf();
    for component in rel.components() {
        match component {
            Component::Normal(c) => {
                let exact = at.join(c);
                if exact.exists() {
                    at = exact;
                    continue;
                }
                let want = c.to_str()?.to_lowercase();
                let entry = std::fs::read_dir(&at)
                    .ok()?
                    .filter_map(Result::ok)
                    .find(|e| {
                        e.file_name().to_str().map(str::to_lowercase) == Some(want.clone())
                    })?;
                at = entry.path();
            }
            Component::CurDir => {}
            Component::ParentDir => at.push(".."),
            // An absolute path was tried as written; its file name is tried on its own.
            Component::RootDir | Component::Prefix(_) => return None,
        }
    }
    at.is_file().then_some(at)
}

/// A text file's contents: a byte-order mark dropped (UTF-16 decoded), UTF-8, or Latin-1 with a note
/// naming the first line that is not UTF-8 (OBJ and MTL statements are ASCII; Latin-1 maps every byte).
pub fn decode(label: &str, bytes: Vec<u8>, notes: &mut Vec<String>) -> String {
    let utf16 = |be: bool| {
        let units = bytes[2..].chunks_exact(2).map(|p| {
            if be {
                u16::from_be_bytes([p[0], p[1]])
            } else {
                u16::from_le_bytes([p[0], p[1]])
            }
        });
        char::decode_utf16(units)
            .map(|c| c.unwrap_or(char::REPLACEMENT_CHARACTER))
            .collect::<String>()
    };
    match bytes.as_slice() {
        [0xFF, 0xFE, ..] => return utf16(false),
        [0xFE, 0xFF, ..] => return utf16(true),
        _ => {}
    }
    let body = bytes
        .strip_prefix(b"\xEF\xBB\xBF")
        .map(<[u8]>::to_vec)
        .unwrap_or(bytes);
    String::from_utf8(body).unwrap_or_else(|e| {
        let at = e.utf8_error().valid_up_to();
        let bytes = e.into_bytes();
        let ends = |c: u8| bytes[..at].iter().filter(|&&b| b == c).count();
        let line = if ends(b'\n') > 0 {
            ends(b'\n')
        } else {
            ends(b'\r')
        } + 1;
        notes.push(format!(
            "{label}:{line}: not UTF-8: the file is read as Latin-1 (ISO 8859-1)"
        ));
        bytes.iter().map(|&b| b as char).collect()
    })
}

/// The file's lines as tobj reads statements, one per line of the file: lone carriage returns end
/// lines, tabs are spaces, indentation is dropped, and a statement ending in `\` takes the next line
/// (which is left empty).
fn lines_of(text: &str) -> Vec<String> {
    let text = text.replace("\r\n", "\n").replace('\r', "\n");
    // tobj reads a statement's keyword from the line's first byte: indentation is dropped.
    let mut lines: Vec<String> = text
        .lines()
        .map(|l| l.replace('\t', " ").trim_start().to_string())
        .collect();
    let mut i = 0;
    while i < lines.len() {
        let mut j = i;
        // A comment ending in `\` (a Windows folder) continues nothing.
        while !lines[i].starts_with('#')
            && lines[i].trim_end().ends_with('\\')
            && j + 1 < lines.len()
        {
            j += 1;
            let next = std::mem::take(&mut lines[j]);
            let head = lines[i]
                .trim_end()
                .trim_end_matches('\\')
                .trim_end()
                .to_string();
            lines[i] = format!("{head} {next}");
        }
        i = j + 1;
    }
    lines
}

/// An OBJ's text as tobj reads it ([`lines_of`]), polylines (`l`) removed (tobj reads an `l` of three or
/// more points as a polygon, a surface the file does not have) and vertex colours dropped. Notes say
/// what was removed.
pub fn obj_text(label: &str, text: &str, notes: &mut Vec<String>) -> String {
    let mut lines = lines_of(text);
    let (mut polylines, mut coloured) = (0usize, 0usize);
    for line in &mut lines {
        let words = line.split_whitespace().count();
        match line.split_whitespace().next() {
            Some("l") => {
                polylines += 1;
                line.clear();
            }
            // Colours are not read: dropped, so that a file colouring only some vertices (which
            // tobj refuses) reads as one colouring none.
            Some("v") if words == 7 => {
                coloured += 1;
                let xyz: Vec<&str> = line.split_whitespace().take(4).collect();
                *line = xyz.join(" ");
            }
            _ => {}
        }
    }
    if polylines > 0 {
        notes.push(format!(
            "{label}: {polylines} polylines (`l` statements) ignored: a line has no surface"
        ));
    }
    if coloured > 0 {
        notes.push(format!(
            "{label}: the colours of {coloured} vertices (`v x y z r g b`) ignored: albedo comes from Kd and map_Kd"
        ));
    }
    lines.join("\n")
}

/// A statement of a .mtl that cannot be read: its line (1-based), the material it is in and why.
#[derive(Debug)]
pub struct MtlError {
    pub line: usize,
    pub material: String,
    pub message: String,
}

/// A .mtl's text as tobj reads it ([`lines_of`]; module doc), and the names of the materials it
/// defines (in order). Notes name what was converted or dropped.
pub fn mtl_text(
    label: &str,
    text: &str,
    notes: &mut Vec<String>,
) -> Result<(String, Vec<String>), MtlError> {
    let mut lines = lines_of(text);
    let mut names: Vec<String> = Vec::new();
    let mut name = String::new();
    for (i, line) in lines.iter_mut().enumerate() {
        let words: Vec<String> = line.split_whitespace().map(str::to_string).collect();
        let Some(key) = words.first().map(String::as_str) else {
            continue;
        };
        let err = |message: String| MtlError {
            line: i + 1,
            material: name.clone(),
            message,
        };
        let number = |w: &str| w.parse::<f32>().ok();
        match key {
            "newmtl" => {
                let n = line.trim()[6..].trim().to_string();
                if n.is_empty() {
                    return Err(err("newmtl needs a material name".into()));
                }
                if names.contains(&n) {
                    notes.push(format!(
                        "{label}:{}: material {n} is defined again: this later definition is used",
                        i + 1
                    ));
                }
                names.push(n.clone());
                name = n;
            }
            "Ka" | "Kd" | "Ks" | "Ke" => {
                let rest = &words[1..];
                // The leading numbers: what follows them (a fourth value, a comment) is not read,
                // as tobj read only three.
                let lead =
                    |w: &[String]| -> Vec<f32> { w.iter().map_while(|w| number(w)).collect() };
                let rgb: Option<[f32; 3]> = match rest.first().map(String::as_str) {
                    Some("spectral") => {
                        notes.push(format!(
                            "{label}:{}: material {name}: {key} spectral (a reflectance curve file) is not read: ignored",
                            i + 1,
                        ));
                        line.clear();
                        continue;
                    }
                    Some("xyz") => match lead(&rest[1..]).as_slice() {
                        [x] => Some(xyz_to_rgb([*x, *x, *x])),
                        [x, y, z, ..] => Some(xyz_to_rgb([*x, *y, *z])),
                        _ => None,
                    },
                    _ => match lead(rest).as_slice() {
                        [r] => Some([*r, *r, *r]),
                        [r, g, b, ..] => Some([*r, *g, *b]),
                        _ => None,
                    },
                };
                let Some(rgb) = rgb else {
                    // Ka is not read (light comes from [[lights]]) and Ke only to be named.
                    if matches!(key, "Ka" | "Ke") {
                        notes.push(format!(
                            "{label}:{}: material {name}: {key} `{}` not read: ignored",
                            i + 1,
                            rest.join(" ")
                        ));
                        line.clear();
                        continue;
                    }
                    return Err(err(format!(
                        "{key} needs one or three numbers (r [g b]), or `xyz x [y z]`, found `{}`",
                        rest.join(" ")
                    )));
                };
                *line = format!("{key} {} {} {}", rgb[0], rgb[1], rgb[2]);
            }
            // Transparency (1 - d), which tobj does not read; exporters disagree on whether Tr 1
            // means clear or opaque, so only a value strictly between is named.
            "Tr" => {
                if words
                    .get(1)
                    .and_then(|w| number(w))
                    .is_some_and(|t| t > 0.0 && t < 1.0)
                {
                    notes.push(format!(
                        "{label}:{}: material {name}: Tr (transparency) ignored: surfaces are opaque",
                        i + 1
                    ));
                }
                line.clear();
            }
            "Ns" | "Ni" | "d" => {
                // `d -halo v`: a dissolve that depends on the view; surfaces are opaque here.
                let v = words[1..]
                    .iter()
                    .find(|w| *w != "-halo")
                    .and_then(|w| number(w));
                let Some(v) = v else {
                    return Err(err(format!(
                        "{key} needs a number, found `{}`",
                        words[1..].join(" ")
                    )));
                };
                *line = format!("{key} {v}");
            }
            // The illumination model is not read (the light-transport contract fixes it); tobj
            // rejects all but an integer.
            "illum" => line.clear(),
            "map_Ka" | "map_Kd" | "map_Ks" | "map_Bump" | "map_bump" | "bump" | "map_Ns"
            | "map_ns" | "map_NS" | "map_d"
                if words.len() < 2 =>
            {
                notes.push(format!(
                    "{label}:{}: material {name}: {key} names no file: ignored",
                    i + 1
                ));
                line.clear();
            }
            _ => {}
        }
    }
    Ok((lines.join("\n"), names))
}

/// CIE XYZ (D65) to linear sRGB (IEC 61966-2-1's matrix), each channel clamped to [0, 1]: an MTL
/// `xyz` colour is a reflectance, as Kd is.
fn xyz_to_rgb([x, y, z]: [f32; 3]) -> [f32; 3] {
    let r = 3.240_454_2 * x - 1.537_138_5 * y - 0.498_531_4 * z;
    let g = -0.969_266 * x + 1.876_010_8 * y + 0.041_556 * z;
    let b = 0.055_643_4 * x - 0.204_025_9 * y + 1.057_225_2 * z;
    [r, g, b].map(|c| if c.is_finite() { c.clamp(0.0, 1.0) } else { c })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn continuation_and_carriage_returns_keep_the_line_count() {
        let l = lines_of("f 1 2 \\\n3\r\nv\t1 2 3\rvn 0 0 1\n# D:\\out\\\n  v 0 0 0");
        assert_eq!(
            l,
            [
                "f 1 2 3",
                "",
                "v 1 2 3",
                "vn 0 0 1",
                "# D:\\out\\",
                "v 0 0 0"
            ]
        );
    }

    #[test]
    fn mtl_colour_forms_are_read_per_statement() {
        let mut notes = Vec::new();
        let (t, names) = mtl_text(
            "m.mtl",
            "newmtl a\nKd 0.5\nKa xyz 0.9505 1 1.089\nKs spectral c.rfl\nd -halo 0.5\nillum 2.0\nTr 0.25\n  Ks 0.1 0.2 0.3 1 # rgba\nKa grey\nTr 1",
            &mut notes,
        )
        .unwrap();
        let l: Vec<&str> = t.split('\n').collect();
        assert_eq!(names, ["a"]);
        assert_eq!(l[1], "Kd 0.5 0.5 0.5");
        // D65 white in XYZ is sRGB white.
        let ka: Vec<f32> = l[2][3..].split(' ').map(|w| w.parse().unwrap()).collect();
        assert!(ka.iter().all(|c| (c - 1.0).abs() < 1e-3), "{ka:?}");
        assert_eq!((l[3], l[4], l[5], l[6]), ("", "d 0.5", "", ""));
        // Indented, with a fourth value and a comment: the three numbers; an unreadable Ka is
        // dropped; Tr 1 (clear or opaque, as the exporter meant) is not named.
        assert_eq!((l[7], l[8], l[9]), ("Ks 0.1 0.2 0.3", "", ""));
        assert_eq!(notes.len(), 3, "{notes:?}");
        assert!(notes[1].contains("Tr (transparency)") && notes[2].contains("Ka `grey`"));
        let e = mtl_text("m.mtl", "newmtl a\nKd 0.5 0.5", &mut notes).unwrap_err();
        assert_eq!((e.line, e.material.as_str()), (2, "a"));
    }
}
