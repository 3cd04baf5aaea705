//! What the binary's tests share: reading the `frames.jsonl` a render or a
//! capture wrote. (Each test crate includes this module and uses part of
//! it.)
#![allow(dead_code)]

use std::path::Path;

/// The keys every `frames.jsonl` record carries (`FrameRecord`'s contract).
pub const FRAME_RECORD_KEYS: [&str; 7] = [
    "seq",
    "timestamp",
    "gain",
    "agc",
    "bits",
    "pixels_crc32c",
    "status",
];

/// The records of `out/frames.jsonl`, one JSON value a line, in order.
pub fn records(out: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(out.join("frames.jsonl"))
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

/// FITS header cards up to END, as (keyword, value text, comment):
/// strings without their quotes, others up to the comment. Read here
/// independently of the writer.
pub fn fits_cards(bytes: &[u8]) -> Vec<(String, String, String)> {
    let mut cards = Vec::new();
    for card in bytes.chunks(80) {
        let card = std::str::from_utf8(card).unwrap();
        if card.starts_with("END ") {
            return cards;
        }
        let (k, rest) = card.split_at(8);
        let v = rest.strip_prefix("= ").unwrap_or(rest).trim();
        let (v, comment) = match v.strip_prefix('\'') {
            Some(s) => {
                // The closing quote is the first one not doubled.
                let mut value = String::new();
                let mut it = s.char_indices().peekable();
                let mut end = s.len();
                while let Some((i, c)) = it.next() {
                    if c == '\'' {
                        if it.peek().map(|p| p.1) == Some('\'') {
                            value.push('\'');
                            it.next();
                            continue;
                        }
                        end = i + 1;
                        break;
                    }
                    value.push(c);
                }
                let comment = s[end..].trim().trim_start_matches('/').trim();
                (value.trim_end().to_string(), comment.to_string())
            }
            None => {
                let (v, c) = v.split_once(" /").unwrap_or((v, ""));
                (v.trim().to_string(), c.trim().to_string())
            }
        };
        cards.push((k.trim().to_string(), v, comment));
    }
    panic!("no END card");
}

/// Seconds since 1970-01-01T00:00:00 of a FITS date
/// `YYYY-MM-DDThh:mm:ss[.sss]` (UTC), by the civil-calendar day count.
pub fn fits_date_unix_s(date: &str) -> f64 {
    let (d, t) = date.split_once('T').expect("date T time");
    let mut ymd = d.split('-').map(|x| x.parse::<i64>().unwrap());
    let (y, m, day) = (
        ymd.next().unwrap(),
        ymd.next().unwrap(),
        ymd.next().unwrap(),
    );
    let mut hms = t.split(':');
    let h: f64 = hms.next().unwrap().parse().unwrap();
    let mi: f64 = hms.next().unwrap().parse().unwrap();
    let s: f64 = hms.next().unwrap().parse().unwrap();
    // Days from 1970-01-01 (Howard Hinnant's algorithm).
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let doy = (153 * ((m + 9) % 12) + 2) / 5 + day - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    let days = era * 146_097 + doe - 719_468;
    days as f64 * 86_400.0 + h * 3600.0 + mi * 60.0 + s
}

/// `cmd` run under a resource limit (`libc::RLIMIT_AS`, `RLIMIT_FSIZE`,
/// …) of `bytes`, set in the child between fork and exec.
#[cfg(unix)]
pub fn limited(
    cmd: &mut std::process::Command,
    resource: libc::__rlimit_resource_t,
    bytes: u64,
) -> &mut std::process::Command {
    use std::os::unix::process::CommandExt;
    // SAFETY: setrlimit only, between fork and exec.
    unsafe {
        cmd.pre_exec(move || {
            let lim = libc::rlimit {
                rlim_cur: bytes,
                rlim_max: bytes,
            };
            if libc::setrlimit(resource, &lim) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        })
    }
}
