//! Which text table a file is, read from its first lines: the delimiter (comma, semicolon, tab,
//! or runs of whitespace), decimal commas, a preamble of comment lines, and whether the first row
//! is a header or data. The `csv` crate then reads the file with that delimiter
//! ([`super::read_csv_report`]); whitespace runs reach it as single tabs ([`WsReader`]).
//!
//! * **Text or binary**: the first [`TEXT_PROBE`] bytes must be UTF-8 without control characters
//!   other than tab, CR and LF. Every binary protocol file (native, UBX, MAVLink, ULog, MCAP)
//!   fails this within its first frame.
//! * **Delimiter**: each candidate splits the first [`MAX_LINES`] lines after the preamble; it
//!   fits when the first line has at least two cells and at least 3/4 of the lines have as many
//!   (a trailing delimiter or a last cell left empty counts as the same). Of those that fit, the
//!   one whose cells after the first line are most often numbers wins (a semicolon file with
//!   decimal commas splits "consistently" at its commas too, into cells like `9610;-0`), ties in
//!   the order comma, semicolon, tab, whitespace.
//! * **Decimal commas**: a delimiter other than the comma, and cells that are numbers only with
//!   their comma read as a point (`0,123`).
//! * **Comments**: leading lines starting with `#`, `%` or `//` (and blank lines) are skipped —
//!   but when the first line after them is data, the last of them is the header if, without its
//!   marker, it splits into as many cells as the data, none a number (EuRoC's `#timestamp [ns],..`,
//!   ROS's `%time,..`).
//! * **Header or not**: the first line after the preamble is data when every cell is a number;
//!   then the file has no header (unless a comment line was it) and its columns must be named by
//!   position (`--columns`).

use std::io::Read;
use std::path::Path;

/// Bytes checked for text (control characters, UTF-8).
pub const TEXT_PROBE: usize = 1024;
/// Bytes read to sniff the table.
pub const SNIFF_BYTES: usize = 64 * 1024;
/// Lines after the preamble a delimiter is judged on.
pub const MAX_LINES: usize = 200;

/// How the cells of a line are separated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Delimiter {
    Comma,
    Semicolon,
    Tab,
    /// Runs of spaces and tabs; leading and trailing whitespace ignored.
    Whitespace,
}

impl Delimiter {
    /// The byte the `csv` crate splits at (whitespace runs arrive as one tab, [`WsReader`]).
    pub fn byte(self) -> u8 {
        match self {
            Delimiter::Comma => b',',
            Delimiter::Semicolon => b';',
            Delimiter::Tab | Delimiter::Whitespace => b'\t',
        }
    }

    /// In words, for the import summary.
    pub fn describe(self) -> &'static str {
        match self {
            Delimiter::Comma => "comma-separated",
            Delimiter::Semicolon => "semicolon-separated",
            Delimiter::Tab => "tab-separated",
            Delimiter::Whitespace => "whitespace-separated",
        }
    }

    const ALL: [Delimiter; 4] = [
        Delimiter::Comma,
        Delimiter::Semicolon,
        Delimiter::Tab,
        Delimiter::Whitespace,
    ];
}

/// How to read a text table.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct TableFormat {
    pub delimiter: Delimiter,
    /// Numbers are written with a decimal comma (`0,123`).
    pub decimal_comma: bool,
    /// Lines before the header, or before the first data row when there is no header.
    pub skip_lines: usize,
    /// Comment lines among them.
    pub comment_lines: usize,
    /// The first line read is a header; `false`: it is data, the columns are named by position.
    pub header: bool,
    /// The header is a comment line whose marker stands alone as its first cell (`# t gx ..`):
    /// that cell is dropped.
    pub marker_cell: bool,
    /// The first data row (line in the file, its text), for a headerless file's error.
    pub first_row: Option<(usize, String)>,
}

impl Default for TableFormat {
    /// A comma-separated file with its header on line 1 (the reading before sniffing).
    fn default() -> Self {
        TableFormat {
            delimiter: Delimiter::Comma,
            decimal_comma: false,
            skip_lines: 0,
            comment_lines: 0,
            header: true,
            marker_cell: false,
            first_row: None,
        }
    }
}

impl TableFormat {
    /// A comma-separated file with its header on line 1: nothing to say about it.
    pub fn is_plain(&self) -> bool {
        self.delimiter == Delimiter::Comma
            && !self.decimal_comma
            && self.skip_lines == 0
            && self.header
    }
}

impl std::fmt::Display for TableFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.delimiter.describe())?;
        if self.decimal_comma {
            write!(f, ", decimal commas (0,5 read as 0.5)")?;
        }
        if self.comment_lines > 0 {
            write!(
                f,
                ", {} skipped",
                crate::text::count(self.comment_lines as u64, "comment line", "comment lines")
            )?;
        }
        if self.header {
            write!(f, ", header on line {}", self.skip_lines + 1)
        } else {
            write!(
                f,
                ", no header (first row on line {}: columns named by position)",
                self.skip_lines + 1
            )
        }
    }
}

/// What a file's first bytes are.
#[derive(Clone, Debug, PartialEq)]
pub enum Sniffed {
    Table(TableFormat),
    /// Text, but no table of numbers: why.
    Text(String),
    /// Empty, unreadable, or not text (a binary protocol file).
    Binary,
}

/// Whitespace runs outside double quotes → one tab; a line's leading and trailing whitespace
/// dropped. Line ends are kept, so line numbers stay the file's.
#[derive(Clone, Debug)]
pub struct WsRuns {
    at_line_start: bool,
    pending: bool,
    quoted: bool,
}

impl Default for WsRuns {
    fn default() -> Self {
        WsRuns {
            at_line_start: true,
            pending: false,
            quoted: false,
        }
    }
}

impl WsRuns {
    pub fn push(&mut self, b: u8, out: &mut Vec<u8>) {
        if self.quoted {
            self.quoted = b != b'"';
            out.push(b);
            return;
        }
        match b {
            b' ' | b'\t' => self.pending = !self.at_line_start,
            b'\n' | b'\r' => {
                self.pending = false;
                self.at_line_start = true;
                out.push(b);
            }
            _ => {
                if self.pending {
                    out.push(b'\t');
                    self.pending = false;
                }
                self.at_line_start = false;
                self.quoted = b == b'"';
                out.push(b);
            }
        }
    }
}

/// A reader of a whitespace-separated table as a tab-separated one ([`WsRuns`]).
pub struct WsReader<R> {
    inner: R,
    runs: WsRuns,
    chunk: Vec<u8>,
    buf: Vec<u8>,
    pos: usize,
}

impl<R: Read> WsReader<R> {
    pub fn new(inner: R) -> Self {
        WsReader {
            inner,
            runs: WsRuns::default(),
            chunk: vec![0; 1 << 16],
            buf: Vec::with_capacity(1 << 16),
            pos: 0,
        }
    }
}

impl<R: Read> Read for WsReader<R> {
    fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
        while self.pos == self.buf.len() {
            self.buf.clear();
            self.pos = 0;
            let n = self.inner.read(&mut self.chunk)?;
            if n == 0 {
                return Ok(0);
            }
            for &b in &self.chunk[..n] {
                self.runs.push(b, &mut self.buf);
            }
        }
        let n = out.len().min(self.buf.len() - self.pos);
        out[..n].copy_from_slice(&self.buf[self.pos..self.pos + n]);
        self.pos += n;
        Ok(n)
    }
}

/// A cell as a number: as written, or (`decimal_comma`) with its one comma read as a point.
pub fn parse_number(cell: &str, decimal_comma: bool) -> Option<f64> {
    let c = cell.trim();
    match c.parse::<f64>() {
        Ok(x) => Some(x),
        Err(_) if decimal_comma && c.contains(',') => c.replacen(',', ".", 1).parse().ok(),
        Err(_) => None,
    }
}

/// A cell that is a value, not a name: a number, a date-time, or a piece of one split off by a
/// whitespace delimiter (`2024-05-01`, `12:00:00.010`): only digits and `-:.+TZ`. Which line
/// is a header is judged by this, so a headerless file whose time column is a date-time keeps
/// its first row.
fn is_value(cell: &str, decimal_comma: bool) -> bool {
    let c = cell.trim();
    parse_number(c, decimal_comma).is_some()
        || super::datetime::parse_datetime_s(c).is_some()
        || (c.bytes().any(|b| b.is_ascii_digit())
            && c.bytes()
                .all(|b| b.is_ascii_digit() || b"-:.+TZ".contains(&b)))
}

/// A cell written with a decimal comma (a number only so).
fn decimal_comma_cell(cell: &str) -> bool {
    let c = cell.trim();
    c.matches(',').count() == 1 && !c.contains('.') && parse_number(c, true).is_some()
}

/// A comment line: `#`, `%` or `//` first (after leading whitespace).
pub fn is_comment(line: &str) -> bool {
    let t = line.trim_start();
    t.starts_with('#') || t.starts_with('%') || t.starts_with("//")
}

/// A cell that is only a comment marker.
pub fn is_marker(cell: &str) -> bool {
    matches!(cell.trim(), "#" | "%" | "//")
}

/// A line's cells split at `d` (quotes as the `csv` crate reads them).
pub fn split(line: &str, d: Delimiter) -> Vec<String> {
    let bytes: Vec<u8> = if d == Delimiter::Whitespace {
        let mut runs = WsRuns::default();
        let mut out = Vec::with_capacity(line.len());
        for &b in line.as_bytes() {
            runs.push(b, &mut out);
        }
        out
    } else {
        line.as_bytes().to_vec()
    };
    let mut rd = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .delimiter(d.byte())
        .from_reader(bytes.as_slice());
    let mut rec = csv::StringRecord::new();
    match rd.read_record(&mut rec) {
        Ok(true) => rec.iter().map(str::to_string).collect(),
        _ => Vec::new(),
    }
}

/// Cells without trailing empty ones.
fn filled(cells: &[String]) -> usize {
    cells
        .iter()
        .rposition(|c| !c.trim().is_empty())
        .map_or(0, |p| p + 1)
}

/// Text: no control characters but tab, CR, LF; UTF-8 (a sequence cut at the end allowed).
pub fn is_text(bytes: &[u8]) -> bool {
    let ok_bytes = bytes
        .iter()
        .all(|&b| !(b < 0x20 && !matches!(b, b'\t' | b'\n' | b'\r') || b == 0x7f));
    ok_bytes
        && match std::str::from_utf8(bytes) {
            Ok(_) => true,
            Err(e) => e.error_len().is_none(),
        }
}

/// Sniff a file's table (a `.gz` decompressed): its first [`SNIFF_BYTES`].
pub fn sniff_file(path: &Path) -> Sniffed {
    let Ok(f) = std::fs::File::open(path) else {
        return Sniffed::Binary;
    };
    let mut r: Box<dyn Read> = if path.extension().is_some_and(|e| e == "gz") {
        Box::new(flate2::read::MultiGzDecoder::new(f))
    } else {
        Box::new(f)
    };
    let mut buf = vec![0u8; SNIFF_BYTES];
    let mut n = 0;
    let mut cut = false;
    while n < buf.len() {
        match r.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            // A corrupt or truncated .gz: sniff what came out; the reader says where it stops.
            Err(_) => {
                cut = true;
                break;
            }
        }
    }
    buf.truncate(n);
    sniff(&buf, cut || n == SNIFF_BYTES)
}

/// Per candidate delimiter: the cells of each line.
struct Split {
    d: Delimiter,
    rows: Vec<Vec<String>>,
}

/// Sniff a table from a file's first bytes (`cut`: the file goes on, so the last line may be
/// partial and is left out).
pub fn sniff(bytes: &[u8], cut: bool) -> Sniffed {
    if bytes.is_empty() || !is_text(&bytes[..bytes.len().min(TEXT_PROBE)]) {
        return Sniffed::Binary;
    }
    let text = String::from_utf8_lossy(bytes);
    let mut text: &str = &text;
    if cut {
        match text.rfind('\n') {
            Some(p) => text = &text[..p],
            None => {
                return Sniffed::Text(format!("no line end in the first {} bytes", bytes.len()));
            }
        }
    }
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let lines: Vec<&str> = text
        .split('\n')
        .map(|l| l.strip_suffix('\r').unwrap_or(l))
        .collect();
    // The preamble: comment and blank lines.
    let start = lines
        .iter()
        .position(|l| !(l.trim().is_empty() || is_comment(l)));
    let Some(start) = start else {
        return Sniffed::Text("only comment and blank lines, no table".into());
    };
    let comments_before = |k: usize| lines[..k].iter().filter(|l| is_comment(l)).count();
    // The body: non-blank lines (their 0-based index), up to MAX_LINES.
    let body: Vec<usize> = (start..lines.len())
        .filter(|&k| !lines[k].trim().is_empty())
        .take(MAX_LINES)
        .collect();
    let splits: Vec<Split> = Delimiter::ALL
        .iter()
        .map(|&d| Split {
            d,
            rows: body.iter().map(|&k| split(lines[k], d)).collect(),
        })
        .collect();
    // A delimiter fits when the first line has ≥ 2 cells and ≥ 3/4 of the lines as many.
    let fits = |s: &Split| {
        let first = &s.rows[0];
        if filled(first) < 2 {
            return false;
        }
        let same = s
            .rows
            .iter()
            .filter(|r| r.len() == first.len() || filled(r) == filled(first))
            .count();
        4 * same >= 3 * s.rows.len()
    };
    // Share of the non-empty cells that are numbers, decimal commas allowed for a delimiter
    // other than the comma; the first line left out when it is names (no number).
    let numeric_share = |s: &Split| {
        let dc = s.d != Delimiter::Comma;
        let names = s.rows[0].iter().all(|c| !is_value(c, dc));
        let from = usize::from(names);
        let (mut num, mut all) = (0usize, 0usize);
        for c in s.rows[from..]
            .iter()
            .flatten()
            .filter(|c| !c.trim().is_empty())
        {
            all += 1;
            num += usize::from(is_value(c, dc));
        }
        if all == 0 {
            0.0
        } else {
            num as f64 / all as f64
        }
    };
    let mut best: Option<(&Split, f64)> = None;
    for s in splits.iter().filter(|s| fits(s)) {
        let share = numeric_share(s);
        if best.is_none_or(|b| share > b.1) {
            best = Some((s, share));
        }
    }
    let Some((s, share)) = best else {
        return Sniffed::Text(format!(
            "no delimiter (comma, semicolon, tab, whitespace) splits line {} and most of the {} after it into the same number of cells, 2 or more",
            start + 1,
            body.len() - 1
        ));
    };
    if share < 0.5 {
        return Sniffed::Text(format!(
            "{} lines, but most cells after line {} are not numbers",
            s.d.describe(),
            start + 1
        ));
    }
    let d = s.d;
    let decimal_comma =
        d != Delimiter::Comma && s.rows.iter().flatten().any(|c| decimal_comma_cell(c));
    let numbers = |r: &[String]| {
        let cells: Vec<&String> = r.iter().filter(|c| !c.trim().is_empty()).collect();
        let n = cells.iter().filter(|c| is_value(c, decimal_comma)).count();
        (n, cells.len())
    };
    let mut f = TableFormat {
        delimiter: d,
        decimal_comma,
        skip_lines: start,
        comment_lines: comments_before(start),
        header: true,
        marker_cell: false,
        first_row: None,
    };
    let (num0, cells0) = numbers(&s.rows[0]);
    if num0 == 0 {
        // Names: the header.
        f.first_row = body.get(1).map(|&k| (k + 1, lines[k].to_string()));
        return Sniffed::Table(f);
    }
    f.first_row = Some((start + 1, lines[start].to_string()));
    // Data first (a ROS export's row has its frame id among the numbers): the last comment
    // line before it (blank lines between allowed) is the header when, without its marker, it
    // has as many cells as the data and none is a number.
    let last_comment = (0..start)
        .rev()
        .find(|&k| !lines[k].trim().is_empty())
        .filter(|&k| is_comment(lines[k]));
    if let Some(k) = last_comment {
        let cells = split(lines[k], d);
        let marker_cell = cells.first().is_some_and(|c| is_marker(c));
        let names = &cells[usize::from(marker_cell)..];
        let stripped = lines[k]
            .trim_start()
            .trim_start_matches("//")
            .trim_start_matches(['#', '%']);
        let (n, c) = numbers(names);
        let first = &s.rows[0];
        if !stripped.trim().is_empty()
            && n == 0
            && c > 0
            && (names.len() == first.len() || filled(names) == filled(first))
        {
            f.skip_lines = k;
            f.comment_lines = comments_before(k);
            f.marker_cell = marker_cell;
            return Sniffed::Table(f);
        }
    }
    // All values: no header. A mix of names and values: the header — unless the next row has
    // names in the same places (a frame id, a status word): then it is data, and taking it
    // for a header would lose it (with --columns, silently).
    let names_where_values_follow = || {
        let next = s.rows.get(1);
        s.rows[0].iter().enumerate().any(|(i, c)| {
            !c.trim().is_empty()
                && !is_value(c, decimal_comma)
                && next.is_none_or(|r| r.get(i).is_some_and(|n| is_value(n, decimal_comma)))
        })
    };
    f.header = num0 < cells0 && names_where_values_follow();
    if f.header {
        f.first_row = body.get(1).map(|&k| (k + 1, lines[k].to_string()));
    }
    Sniffed::Table(f)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(text: &str) -> TableFormat {
        match sniff(text.as_bytes(), false) {
            Sniffed::Table(f) => f,
            other => panic!("{other:?} for {text:?}"),
        }
    }

    #[test]
    fn delimiters() {
        assert_eq!(table("t,gx,ax\n1,2,3\n2,3,4\n").delimiter, Delimiter::Comma);
        assert_eq!(
            table("t;gx;ax\n1;2;3\n2;3;4\n").delimiter,
            Delimiter::Semicolon
        );
        assert_eq!(table("t\tgx\tax\n1\t2\t3\n").delimiter, Delimiter::Tab);
        // A tab file with an empty cell stays tab-separated (the cell is a missing value).
        let f = table("t\tgx\tax\n1\t\t3\n2\t3\t4\n");
        assert_eq!(f.delimiter, Delimiter::Tab);
        assert_eq!(
            table("  t   gx  ax\n 1.0  2.0 3\n 2.0 3.5  4\n").delimiter,
            Delimiter::Whitespace
        );
        // Names with spaces in a comma file stay comma-separated.
        let f = table("Time (s),Gyroscope X (deg/s),Accelerometer X (g)\n0.1,0.2,0.3\n");
        assert_eq!(f.delimiter, Delimiter::Comma);
        assert!(f.is_plain());
        // Quoted names with the delimiter inside.
        assert_eq!(
            table("\"t, s\",\"gx, rad/s\"\n1,2\n").delimiter,
            Delimiter::Comma
        );
    }

    #[test]
    fn decimal_commas() {
        let f = table("time;ax;ay\n0,5;1,25;-0,017\n1,5;1;2,5\n");
        assert_eq!(f.delimiter, Delimiter::Semicolon);
        assert!(f.decimal_comma);
        // Headerless: splitting at the commas is consistent too, but its cells are no numbers.
        let f = table("1756402240,9610;-0,017;1,011\n1756402240,9670;-0,018;1,012\n");
        assert_eq!(f.delimiter, Delimiter::Semicolon);
        assert!(f.decimal_comma && !f.header);
        assert!(!table("t;gx\n0.5;1\n").decimal_comma);
        assert_eq!(parse_number(" -0,017", true), Some(-0.017));
        assert_eq!(parse_number("-0,017", false), None);
        assert_eq!(parse_number("1.234,5", true), None);
    }

    #[test]
    fn comments_and_headers() {
        let f = table("# recorded by x\n% units g\n\n// more\nt,gx,ax\n1,2,3\n");
        assert_eq!((f.skip_lines, f.comment_lines, f.header), (4, 3, true));
        // EuRoC: the header is the comment line.
        let f = table("#timestamp [ns],w_RS_S_x [rad s^-1],a_RS_S_x [m s^-2]\n1,2,3\n");
        assert_eq!((f.skip_lines, f.header), (0, true));
        assert!(f.is_plain());
        // ROS, after a preamble; its rows hold a frame id among the numbers.
        let f = table(
            "# exported\n%time,field.header.frame_id,field.angular_velocity.x\n1,imu_link,3\n",
        );
        assert_eq!((f.skip_lines, f.comment_lines, f.header), (1, 1, true));
        // A first line of names and numbers with no comment before it is the header.
        let f = table("t,1,2\n1,2,3\n");
        assert_eq!((f.skip_lines, f.header), (0, true));
        // A whitespace header with its marker standing alone.
        let f = table("# comment\n# timestamp wx ax\n1 2 3\n4 5 6\n");
        assert_eq!((f.skip_lines, f.header, f.marker_cell), (1, true, true));
        // A comment that is no header (wrong count, or numbers): the file has none.
        let f = table("# recorded 2024 at 200 Hz\n1 2 3\n4 5 6\n");
        assert!(!f.header);
        assert_eq!(f.skip_lines, 1);
        assert_eq!(f.first_row, Some((2, "1 2 3".to_string())));
        let f = table("# a b 3\n1 2 3\n4 5 6\n");
        assert!(!f.header);
    }

    #[test]
    fn not_tables() {
        assert_eq!(
            sniff(&[0xb5, 0x62, 0x10, 0x03, 0, 0], false),
            Sniffed::Binary
        );
        assert_eq!(sniff(b"", false), Sniffed::Binary);
        assert!(matches!(
            sniff(
                b"Some notes.\nThis file, written by hand, has prose.\nNo numbers here at all\n",
                false
            ),
            Sniffed::Text(_)
        ));
        assert!(matches!(
            sniff(b"# only a comment\n\n", false),
            Sniffed::Text(_)
        ));
        // A cut last line is left out.
        let f = table("t,gx\n1,2\n3,4\n5");
        assert_eq!(f.delimiter, Delimiter::Comma);
    }

    #[test]
    fn whitespace_runs_become_one_tab_outside_quotes() {
        let mut r = WsReader::new("  a   b\t\t c  \r\n\"x  y\"  2\n".as_bytes());
        let mut s = String::new();
        r.read_to_string(&mut s).unwrap();
        assert_eq!(s, "a\tb\tc\r\n\"x  y\"\t2\n");
    }
}
