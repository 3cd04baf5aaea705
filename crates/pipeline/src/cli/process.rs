//! The `gloam` process's start and end: worker threads, logging, clap's
//! own exits. Here rather than in `src/` so the binary stays a list of
//! commands; each piece is what a hostile environment taught (see
//! docs/reliability.md).

use std::io::Write as _;
use std::process::ExitCode;

use gloam_io::RunGuard;
use gloam_io::guard::AfterInterrupt;

/// Refuses a `RAYON_NUM_THREADS` past the tracer's own thread limit:
/// rayon would try to start that many workers (100 000 hang the start).
fn check_thread_env() -> Result<(), String> {
    let Some(v) = std::env::var_os("RAYON_NUM_THREADS") else {
        return Ok(());
    };
    let max = gloam_trace::tracer::MAX_THREADS;
    match v.to_str().map(str::trim).map(str::parse::<u64>) {
        Some(Ok(n)) if n as u128 > max as u128 => Err(format!(
            "RAYON_NUM_THREADS={n}: at most {max} worker threads (unset it, or use --threads where a command has it)"
        )),
        Some(Ok(_)) => Ok(()),
        _ => Err(format!(
            "RAYON_NUM_THREADS={}: not a whole number of threads",
            v.to_string_lossy()
        )),
    }
}

/// Starts the worker pool up front, where a failure is an error: started
/// lazily, a pool whose threads could not start (`RAYON_NUM_THREADS=1024`
/// under `ulimit -v`) panicked in the first parallel loop.
pub fn start_workers() -> Result<(), String> {
    check_thread_env()?;
    rayon::ThreadPoolBuilder::new().build_global().map_err(|e| {
        format!(
            "starting {} worker threads (RAYON_NUM_THREADS, else one per core): {e}; each needs its own stack, which an address-space or process limit (ulimit -v, -u) can refuse",
            std::env::var("RAYON_NUM_THREADS").unwrap_or_else(|_| "the".into())
        )
    })
}

/// The process's [`RunGuard`], made from the command line `matches` was
/// parsed from, and the interrupt handler (Ctrl-C, SIGTERM, SIGHUP) that
/// acts on it: child processes killed; a polling loop (a capture) left to
/// stop and publish what it has; otherwise every unpublished set removed
/// and the process ended with 130. The guard is the binary's: a library
/// holds no process-wide list of sets or children.
pub fn guard_this_run(matches: &clap::ArgMatches) -> RunGuard {
    // The subcommand path (`calibrate agc`): its words are not inputs.
    let mut words = Vec::new();
    let mut m = matches;
    while let Some((name, sub)) = m.subcommand()
        && words.len() < gloam_io::guard::MAX_COMMAND_WORDS
    {
        words.push(name.into());
        m = sub;
    }
    let guard = RunGuard::for_command_line(std::env::args_os().skip(1), &words);
    let on_signal = guard.clone();
    let installed = ctrlc::set_handler(move || match on_signal.on_interrupt() {
        AfterInterrupt::Continue => {}
        AfterInterrupt::Exit { had_sets } => {
            let what = if had_sets {
                ": nothing was published"
            } else {
                ""
            };
            let _ = writeln!(std::io::stderr(), "interrupted{what}");
            std::process::exit(130);
        }
    });
    if let Err(e) = installed {
        tracing::warn!("no interrupt handler ({e}): Ctrl-C leaves a partial output set behind");
    }
    guard
}

/// The command line with `--flag -1e-3` written `--flag=-1e-3`: clap takes
/// `-1.5` and `-1e3` as a flag's value but not a number whose exponent has
/// a sign, and `gloam sky --lat -1e-3` failed with "unexpected argument
/// '-1'". Only a long flag that takes a value in the (sub)command reached so
/// far, followed by a whole signed float, is joined: `--json -1e-3` stays
/// two words for clap to judge. `cmd` is built here (global flags reach
/// the subcommands).
pub fn args_with_signed_exponents(
    cmd: &mut clap::Command,
    args: impl IntoIterator<Item = std::ffi::OsString>,
) -> Vec<std::ffi::OsString> {
    cmd.build();
    let mut at: &clap::Command = cmd;
    let mut out: Vec<std::ffi::OsString> = Vec::new();
    // The last word is a long flag (no `=`) whose value comes next.
    let mut value_next = false;
    for (i, a) in args.into_iter().enumerate() {
        let text = a.to_str();
        let signed_exponent = text.is_some_and(|v| {
            v.starts_with('-')
                && (v.contains("e-") || v.contains("e+") || v.contains("E-") || v.contains("E+"))
                && v.parse::<f64>().is_ok()
        });
        if let Some(flag) = out.last_mut().filter(|_| value_next && signed_exponent) {
            flag.push("=");
            flag.push(&a);
            value_next = false;
            continue;
        }
        if i > 0
            && !value_next
            && let Some(sub) = text.and_then(|v| at.find_subcommand(v))
        {
            at = sub;
        }
        value_next = text
            .and_then(|v| v.strip_prefix("--"))
            .filter(|name| !name.is_empty() && !name.contains('='))
            .and_then(|name| {
                at.get_arguments().find(|arg| {
                    arg.get_long() == Some(name)
                        || arg.get_all_aliases().is_some_and(|al| al.contains(&name))
                })
            })
            .is_some_and(|arg| arg.get_action().takes_values());
        out.push(a);
    }
    out
}

/// What clap's "invalid UTF-8 was detected in one or more arguments"
/// leaves out: which argument, and of which flag. The first argument that
/// is not UTF-8, named with its flag (`--set`, or `--band` before it) and
/// shown with its bytes escaped. Paths take any bytes; a text flag's value
/// (a setting, a URI, a band, a number) cannot.
pub fn non_utf8_argument(args: &[std::ffi::OsString]) -> Option<String> {
    let at = args.iter().skip(1).position(|a| a.to_str().is_none())? + 1;
    let shown = format!("{:?}", args[at]);
    let lossy = args[at].to_string_lossy();
    let flag = match lossy.split_once('=') {
        Some((f, _)) if f.starts_with("--") => Some(f.to_string()),
        _ => args[at - 1]
            .to_str()
            .filter(|p| p.starts_with('-') && at > 1)
            .map(str::to_string),
    };
    Some(match flag {
        Some(f) => format!(
            "{f}: its value {shown} is not UTF-8 text; this flag takes text (only file paths may hold other bytes)"
        ),
        None => {
            format!("argument {at} ({shown}) is not UTF-8 text, and this command takes it as text")
        }
    })
}

/// The command line parsed by `cmd` ([`args_with_signed_exponents`]
/// first), or the exit of a run that ends here: clap's error, `--help`, or
/// a word that is not UTF-8 named with its flag ([`non_utf8_argument`]).
pub fn parse_command_line(mut cmd: clap::Command) -> Result<clap::ArgMatches, ExitCode> {
    let args = args_with_signed_exponents(&mut cmd, std::env::args_os());
    match cmd.try_get_matches_from(args) {
        Ok(m) => Ok(m),
        Err(e) if e.kind() == clap::error::ErrorKind::InvalidUtf8 => {
            // The raw command line: the pre-pass joins only UTF-8 words.
            let words: Vec<_> = std::env::args_os().collect();
            match non_utf8_argument(&words) {
                Some(what) => {
                    let _ = writeln!(std::io::stderr(), "error: {what}");
                    Err(ExitCode::from(2))
                }
                None => Err(clap_exit(e)),
            }
        }
        Err(e) => Err(clap_exit(e)),
    }
}

/// A write past the file-size limit (`ulimit -f`) fails with `EFBIG`, an
/// error that names the file and removes the staging directory, instead of
/// SIGXFSZ ending the process without a word and leaving the staging
/// directory behind. Called first thing in `main`.
pub fn file_size_limit_is_an_error() {
    #[cfg(unix)]
    // SAFETY: sets this process's disposition of one signal to "ignore";
    // no handler runs, no memory of ours is touched.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
}

/// `cmd` and all its subcommands taking negative numbers as values, so that
/// `--spp -5` is refused by the flag's own check ("invalid value '-5' for
/// '--spp'") rather than by clap's misleading "use '-- -5'" tip.
pub fn negative_numbers_are_values(cmd: clap::Command) -> clap::Command {
    cmd.allow_negative_numbers(true)
        .mut_subcommands(negative_numbers_are_values)
}

/// `text` with every number written in more than [`LONG_NUMBER`]
/// characters rewritten in exponent form (`1e300`, `-1e-320`): a value
/// echoed with `{}` somewhere in a message (a clap value parser, a
/// `--fault-drop` range, a scope level) printed 300 digits. The one
/// place every error of the command line passes; a run of digits inside
/// a word or a path (`run-2026…/`) is left as written.
pub fn short_numbers(text: &str) -> String {
    let b = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let (mut i, mut copied) = (0, 0);
    let joined = |c: u8| c.is_ascii_alphanumeric() || c == b'_' || c == b'/';
    // Bounded: `i` advances on every step.
    while i < b.len() {
        let starts = (b[i].is_ascii_digit()
            || (b[i] == b'-' && b.get(i + 1).is_some_and(u8::is_ascii_digit)))
            && (i == 0 || !joined(b[i - 1]));
        if !starts {
            i += 1;
            continue;
        }
        let mut j = i + 1;
        while j < b.len() && (b[j].is_ascii_digit() || b[j] == b'.') {
            j += 1;
        }
        // A trailing full stop ends the sentence, not the number.
        let end = if b[j - 1] == b'.' { j - 1 } else { j };
        let long = end - i > LONG_NUMBER && (j == b.len() || !joined(b[j]));
        match text[i..end].parse::<f64>() {
            Ok(x) if long => {
                out.push_str(&text[copied..i]);
                out.push_str(&gloam_spectra::num(x));
                copied = end;
            }
            _ => {}
        }
        i = j;
    }
    out.push_str(&text[copied..]);
    out
}

/// Characters past which a number in a message is rewritten
/// ([`short_numbers`]): longer than any 64-bit count or 17-digit float.
const LONG_NUMBER: usize = 24;

/// Ends on a clap error, or prints `--help`/`--version`, whose write
/// errors clap drops: `gloam --help > /dev/full` exited 0 with nothing
/// written. A closed stdout ends quietly, as every command's output does.
pub fn clap_exit(e: clap::Error) -> ExitCode {
    use clap::error::ErrorKind;
    if !matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) {
        // As `e.exit()` would, with its numbers short (`--fault-drop
        // 1e300` echoed 301 digits).
        let _ = write!(std::io::stderr(), "{}", short_numbers(&e.to_string()));
        return ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(2));
    }
    match e.print().and_then(|()| std::io::stdout().flush()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(w) if w.kind() == std::io::ErrorKind::BrokenPipe => ExitCode::SUCCESS,
        Err(w) => {
            let _ = writeln!(std::io::stderr(), "error: writing to stdout: {w}");
            ExitCode::FAILURE
        }
    }
}

/// Logs to stderr at `RUST_LOG`'s filter when set (and not empty), else
/// `--log`'s; plain text when stderr is a file or pipe (CI logs, tests).
pub fn init_logging(log: &str) {
    tracing_subscriber::fmt()
        .with_env_filter(log_filter(log))
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
}

/// The log filter: `RUST_LOG` when set (and not empty), else `--log`. A
/// `RUST_LOG` that is not a filter — or not text — was dropped silently
/// for `--log`'s; it is named on stderr now (`--log` itself warns through
/// the filter's own parser).
fn log_filter(log: &str) -> tracing_subscriber::EnvFilter {
    use tracing_subscriber::EnvFilter;
    let Some(var) = std::env::var_os("RUST_LOG").filter(|v| !v.is_empty()) else {
        return EnvFilter::new(log);
    };
    let parsed = match var.to_str() {
        Some(text) => EnvFilter::try_new(text).map_err(|e| e.to_string()),
        None => Err("it is not UTF-8".to_string()),
    };
    parsed.unwrap_or_else(|why| {
        let _ = writeln!(
            std::io::stderr(),
            "warning: RUST_LOG={var:?} is not a log filter ({why}): ignored, logging at --log {log}"
        );
        EnvFilter::new(log)
    })
}

#[cfg(test)]
mod tests {
    use super::{args_with_signed_exponents, non_utf8_argument, short_numbers};
    use std::os::unix::ffi::OsStringExt;

    #[test]
    fn long_numbers_in_messages_are_written_short() {
        let huge = format!("{}", 1e300_f64);
        let tiny = format!("{}", -1e-320_f64);
        assert!(huge.len() > 300 && tiny.len() > 300);
        let m = short_numbers(&format!(
            "--fault-drop {huge} is not a probability; {tiny}."
        ));
        assert_eq!(m, "--fault-drop 1e300 is not a probability; -1e-320.");
        // Counts, 17-digit floats, paths and words keep their digits.
        for kept in [
            "frames 18446744073709551615, gain 0.12345678901234567",
            "run/20261207224300123456789012345/x",
            "id_20261207224300123456789012345",
        ] {
            assert_eq!(short_numbers(kept), kept);
        }
        assert_eq!(short_numbers(""), "");
        assert_eq!(short_numbers("-"), "-");
    }

    #[test]
    fn a_non_utf8_argument_is_named_with_its_flag() {
        let bad = || OsString::from_vec(b"v\xff".to_vec());
        let line = |words: Vec<OsString>| non_utf8_argument(&words).unwrap_or_default();
        let m = line(vec!["g".into(), "probe".into(), "--band".into(), bad()]);
        assert!(m.starts_with("--band: its value \"v\\xFF\""), "{m}");
        let mut set = OsString::from("--set=");
        set.push(bad());
        let m = line(vec!["g".into(), "render".into(), set]);
        assert!(m.starts_with("--set: "), "{m}");
        let m = line(vec!["g".into(), bad()]);
        assert!(m.starts_with("argument 1 "), "{m}");
        assert!(non_utf8_argument(&["g".into(), "render".into()]).is_none());
    }
    use std::ffi::OsString;

    fn joined(args: &[&str]) -> Vec<String> {
        let mut cmd = clap::Command::new("g")
            .arg(
                clap::Arg::new("json")
                    .long("json")
                    .action(clap::ArgAction::SetTrue),
            )
            .subcommand(
                clap::Command::new("sky")
                    .arg(
                        clap::Arg::new("lat")
                            .long("lat")
                            .allow_negative_numbers(true),
                    )
                    .arg(
                        clap::Arg::new("quiet")
                            .long("quiet")
                            .action(clap::ArgAction::SetTrue),
                    )
                    .arg(clap::Arg::new("at").allow_negative_numbers(true)),
            );
        let words = args.iter().map(OsString::from);
        args_with_signed_exponents(&mut cmd, words)
            .into_iter()
            .map(|w| w.into_string().unwrap())
            .collect()
    }

    /// Joined only after a flag that takes a value, in the subcommand
    /// the words reached; a flag without a value keeps its neighbour.
    #[test]
    fn only_a_flag_that_takes_a_value_is_joined() {
        assert_eq!(
            joined(&["g", "sky", "--lat", "-1e-3"]),
            ["g", "sky", "--lat=-1e-3"]
        );
        assert_eq!(
            joined(&["g", "sky", "--quiet", "-1e-3"]),
            ["g", "sky", "--quiet", "-1e-3"]
        );
        // `--lat` is the subcommand's flag, unknown before it.
        assert_eq!(joined(&["g", "--lat", "-1e-3"]), ["g", "--lat", "-1e-3"]);
        // Not a signed exponent, or already joined: untouched.
        assert_eq!(
            joined(&["g", "sky", "--lat", "-1.5"]),
            ["g", "sky", "--lat", "-1.5"]
        );
        assert_eq!(
            joined(&["g", "sky", "--lat=-1e-3"]),
            ["g", "sky", "--lat=-1e-3"]
        );
        // A value equal to a subcommand's name is a value, not a descent.
        assert_eq!(
            joined(&["g", "sky", "--lat", "sky", "--json", "-1e+2"]),
            ["g", "sky", "--lat", "sky", "--json", "-1e+2"]
        );
    }
}
