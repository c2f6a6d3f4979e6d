//! `pipeline serve`: a small static HTTP/1.1 server for a bake folder and the browser
//! viewer (issue 33; paper 000 §3.2's run-time streaming, cell packs fetched as the
//! viewer moves; byte layout `format/README.md` "Pack files", read by the viewer in
//! `player/web/src/pack.ts`).
//!
//! Mounts (all `GET` or `HEAD`):
//!
//! - `/bake/<path>`: files of the bake folder (`index.pack`, `base.pack`,
//!   `cells/<id>.pack`, `groups/<id>.pack`, `textures/<h>/<h>.tex`, …);
//! - `/shader.wgsl`: the player's WGSL exactly as the native player compiles it
//!   (`format::shading::wgsl_constants()` then `player/src/shader.wgsl`, included at
//!   build time: the same text as `player::gpu::shader_source()`, so the two viewers
//!   cannot drift; `tests/web.rs` checks the equality);
//! - `/<path>`: the viewer's files (`player/web`: `index.html`, `dist/viewer.js`).
//!
//! `Range: bytes=a-b`, `bytes=a-` and `bytes=-n` get `206 Partial Content` with
//! `Content-Range`; a range that starts past the end, a malformed one or a list of
//! several gets `416` with `Content-Range: bytes */len` (one range per request is all
//! the viewer asks for). A path with a `..`, `.`, backslash, NUL or bad percent-escape
//! component gets `403`; one that resolves (through a link) outside its folder gets
//! `403`; a missing file `404`. Each connection is one thread (at most
//! [`MAX_CONNECTIONS`], then `503`), with read and write timeouts; no request makes the
//! server panic.

use std::fs::File;
use std::io::{BufRead, BufReader, Read, Seek, SeekFrom, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Duration;

/// Most connections served at once; more get `503`.
pub const MAX_CONNECTIONS: usize = 64;
/// Longest request head (request line and headers) read.
const MAX_HEAD: usize = 16 * 1024;
/// How long an idle keep-alive connection is kept.
const IDLE: Duration = Duration::from_secs(10);

/// The player's WGSL as the native player compiles it (see the module docs).
pub fn shader_source() -> String {
    format!(
        "{}{}",
        format::shading::wgsl_constants(),
        include_str!("../../player/src/shader.wgsl")
    )
}

/// `pipeline serve` arguments.
#[derive(clap::Args, Debug, Clone)]
pub struct ServeArgs {
    /// The bake folder to serve under `/bake/`.
    pub out: PathBuf,
    /// TCP port (0 = any free port; the line printed at start names it).
    #[arg(long, default_value_t = 8080)]
    pub port: u16,
    /// Address to listen on.
    #[arg(long, default_value = "127.0.0.1")]
    pub bind: String,
    /// The viewer's folder served at `/` (default: this source tree's `player/web`).
    #[arg(long)]
    pub web: Option<PathBuf>,
    /// Serve files only, as a static host would: no derived `<pack>.vertices` and
    /// `<pack>.textures` (the viewer then reads base.pack ranges and single store
    /// files; format/README.md "Derived files for the browser").
    #[arg(long = "static")]
    pub static_only: bool,
}

/// What the server serves.
#[derive(Clone, Debug)]
pub struct Roots {
    pub bake: PathBuf,
    pub web: PathBuf,
    /// Derive `<pack>.vertices` and `<pack>.textures` on request.
    pub derive: bool,
}

/// The viewer folder of this source tree.
pub fn default_web_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../player/web")
}

/// Runs `pipeline serve` until killed.
pub fn serve(args: &ServeArgs) -> anyhow::Result<()> {
    let bake = args
        .out
        .canonicalize()
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.out.display()))?;
    if !bake.join("index.pack").is_file() {
        anyhow::bail!(
            "{}: no index.pack here (not a finished bake; run `pipeline run` first)",
            bake.display()
        );
    }
    let web_arg = args.web.clone().unwrap_or_else(default_web_dir);
    let web = web_arg
        .canonicalize()
        .map_err(|e| anyhow::anyhow!("viewer folder {}: {e}", web_arg.display()))?;
    if !web.join("dist/viewer.js").is_file() {
        eprintln!(
            "pipeline serve: warning: {} has no dist/viewer.js (run scripts/install-web.sh); the page will not start",
            web.display()
        );
    }
    let listener = TcpListener::bind((args.bind.as_str(), args.port))
        .map_err(|e| anyhow::anyhow!("cannot listen on {}:{}: {e}", args.bind, args.port))?;
    let addr = listener.local_addr()?;
    println!(
        "serving {} at http://{addr}/?bake=/bake/ (viewer {})",
        bake.display(),
        web.display()
    );
    std::io::stdout().flush()?;
    run_listener(
        listener,
        Roots {
            bake,
            web,
            derive: !args.static_only,
        },
    );
    Ok(())
}

/// Accepts connections forever, one thread each.
pub fn run_listener(listener: TcpListener, roots: Roots) {
    let roots = Arc::new(roots);
    let live = Arc::new(AtomicUsize::new(0));
    for stream in listener.incoming() {
        let Ok(mut stream) = stream else { continue };
        if live.fetch_add(1, Ordering::SeqCst) >= MAX_CONNECTIONS {
            live.fetch_sub(1, Ordering::SeqCst);
            let _ = write_head(&mut stream, 503, "Service Unavailable", &[], 0, true);
            continue;
        }
        let (roots, mine) = (roots.clone(), live.clone());
        let spawned = std::thread::Builder::new()
            .name("serve".into())
            .spawn(move || {
                let _ = connection(stream, &roots);
                mine.fetch_sub(1, Ordering::SeqCst);
            });
        if spawned.is_err() {
            // The closure (and its counter decrement) never ran.
            live.fetch_sub(1, Ordering::SeqCst);
        }
    }
}

/// One parsed request head.
#[derive(Debug, PartialEq)]
struct Request {
    method: String,
    target: String,
    range: Option<String>,
    close: bool,
    /// The client accepts `Content-Encoding: zstd` (a browser's `Accept-Encoding`).
    zstd: bool,
}

/// Reads one request head; `Ok(None)` at a clean end of the connection.
fn read_request(r: &mut impl BufRead) -> Result<Option<Request>, u16> {
    let mut head = Vec::new();
    loop {
        let mut line = Vec::new();
        let n = r
            .by_ref()
            .take((MAX_HEAD - head.len()) as u64 + 1)
            .read_until(b'\n', &mut line)
            .map_err(|_| 400u16)?;
        if n == 0 {
            return if head.is_empty() { Ok(None) } else { Err(400) };
        }
        if !line.ends_with(b"\n") {
            return Err(431);
        }
        head.extend_from_slice(&line);
        if head.len() > MAX_HEAD {
            return Err(431);
        }
        if line == b"\r\n" || line == b"\n" {
            if head.len() == line.len() {
                // Blank lines before a request line are allowed (RFC 9112 §2.2).
                head.clear();
                continue;
            }
            break;
        }
    }
    let text = std::str::from_utf8(&head).map_err(|_| 400u16)?;
    let mut lines = text.lines();
    let first = lines.next().ok_or(400u16)?;
    let mut parts = first.split(' ');
    let (Some(method), Some(target), Some(version), None) =
        (parts.next(), parts.next(), parts.next(), parts.next())
    else {
        return Err(400);
    };
    if !version.starts_with("HTTP/1.") {
        return Err(505);
    }
    let mut req = Request {
        method: method.to_string(),
        target: target.to_string(),
        range: None,
        close: version == "HTTP/1.0",
        zstd: false,
    };
    for line in lines {
        let Some((name, value)) = line.split_once(':') else {
            if line.is_empty() {
                continue;
            }
            return Err(400);
        };
        let value = value.trim();
        if name.eq_ignore_ascii_case("range") {
            req.range = Some(value.to_string());
        } else if name.eq_ignore_ascii_case("accept-encoding") {
            req.zstd = value.split(',').any(|c| {
                c.split(';')
                    .next()
                    .unwrap_or("")
                    .trim()
                    .eq_ignore_ascii_case("zstd")
            });
        } else if name.eq_ignore_ascii_case("connection") {
            let v = value.to_ascii_lowercase();
            req.close = v.contains("close") || (req.close && !v.contains("keep-alive"));
        }
    }
    Ok(Some(req))
}

fn connection(stream: TcpStream, roots: &Roots) -> std::io::Result<()> {
    stream.set_read_timeout(Some(IDLE))?;
    stream.set_write_timeout(Some(Duration::from_secs(30)))?;
    let _ = stream.set_nodelay(true);
    let mut out = stream.try_clone()?;
    let mut input = BufReader::new(stream);
    loop {
        let req = match read_request(&mut input) {
            Ok(Some(r)) => r,
            Ok(None) => return Ok(()),
            Err(code) => {
                return error_response(&mut out, code, true);
            }
        };
        respond(&mut out, &req, roots)?;
        if req.close {
            return Ok(());
        }
    }
}

/// `Cache-Control` of a file whose name is its content (issue 32): a published pack
/// (`cells/<id>-<h>.pack`, `base-<h>.pack`, format::pack::generation) or a capture
/// of the texture store (`textures/<h[0..2]>/<h>.tex`). Everything else, `index.pack`
/// first, is `no-cache`: a rebake replaces it.
const IMMUTABLE: &str = "public, max-age=31536000, immutable";

fn immutable(path: &Path) -> bool {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
    format::pack::generation::is_published_file_name(name)
        || (name.ends_with(".tex")
            && name.len() == 64 + 4
            && name[..64].bytes().all(|b| b.is_ascii_hexdigit()))
}

fn reason(code: u16) -> &'static str {
    match code {
        200 => "OK",
        206 => "Partial Content",
        400 => "Bad Request",
        403 => "Forbidden",
        404 => "Not Found",
        405 => "Method Not Allowed",
        416 => "Range Not Satisfiable",
        431 => "Request Header Fields Too Large",
        500 => "Internal Server Error",
        503 => "Service Unavailable",
        505 => "HTTP Version Not Supported",
        _ => "Error",
    }
}

fn write_head(
    out: &mut impl Write,
    code: u16,
    why: &str,
    headers: &[(&str, String)],
    len: u64,
    close: bool,
) -> std::io::Result<()> {
    let mut h = format!("HTTP/1.1 {code} {why}\r\nContent-Length: {len}\r\n");
    for (k, v) in headers {
        h.push_str(&format!("{k}: {v}\r\n"));
    }
    h.push_str("Access-Control-Allow-Origin: *\r\n");
    if !headers.iter().any(|(k, _)| *k == "Cache-Control") {
        h.push_str("Cache-Control: no-cache\r\n");
    }
    if close {
        h.push_str("Connection: close\r\n");
    }
    h.push_str("\r\n");
    out.write_all(h.as_bytes())
}

fn error_response(out: &mut impl Write, code: u16, close: bool) -> std::io::Result<()> {
    let body = format!("{code} {}\n", reason(code));
    write_head(
        out,
        code,
        reason(code),
        &[("Content-Type", "text/plain; charset=utf-8".into())],
        body.len() as u64,
        close,
    )?;
    out.write_all(body.as_bytes())?;
    out.flush()
}

/// Where a request target points.
#[derive(Debug, PartialEq)]
enum Target {
    Shader,
    File(PathBuf),
}

/// Maps a request target to a file under `roots` (before the link check).
fn resolve(target: &str, roots: &Roots) -> Result<Target, u16> {
    let path = target.split(['?', '#']).next().unwrap_or("");
    if !path.starts_with('/') {
        return Err(400);
    }
    let parts = safe_components(path)?;
    if parts == ["shader.wgsl"] {
        return Ok(Target::Shader);
    }
    let (root, rest) = match parts.first().map(String::as_str) {
        Some("bake") => (&roots.bake, &parts[1..]),
        _ => (&roots.web, &parts[..]),
    };
    let mut p = root.clone();
    for c in rest {
        p.push(c);
    }
    Ok(Target::File(p))
}

/// The percent-decoded, non-empty components of a URL path; `403` for any `.`, `..`,
/// backslash, NUL, control character or undecodable escape.
fn safe_components(path: &str) -> Result<Vec<String>, u16> {
    let mut out = Vec::new();
    for raw in path.split('/') {
        if raw.is_empty() {
            continue;
        }
        let c = percent_decode(raw).ok_or(403u16)?;
        if c == "." || c == ".." || c.contains(['\\', '/', '\0']) || c.chars().any(char::is_control)
        {
            return Err(403);
        }
        out.push(c);
    }
    Ok(out)
}

fn percent_decode(s: &str) -> Option<String> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = b.get(i + 1..i + 3)?;
            let v = u8::from_str_radix(std::str::from_utf8(hex).ok()?, 16).ok()?;
            out.push(v);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// A byte range `start..end` (end exclusive) of a file of length `len`, from a `Range`
/// header value; `None` = answer 416.
pub fn parse_range(value: &str, len: u64) -> Option<(u64, u64)> {
    let spec = value.trim().strip_prefix("bytes=")?.trim();
    if spec.contains(',') {
        return None;
    }
    let (a, b) = spec.split_once('-')?;
    let (a, b) = (a.trim(), b.trim());
    let num = |s: &str| -> Option<u64> {
        if s.is_empty() || !s.bytes().all(|c| c.is_ascii_digit()) {
            return None;
        }
        s.parse::<u64>().ok()
    };
    if a.is_empty() {
        // Suffix: the last n bytes.
        let n = num(b)?;
        if n == 0 || len == 0 {
            return None;
        }
        return Some((len - n.min(len), len));
    }
    let start = num(a)?;
    if start >= len {
        return None;
    }
    let end = if b.is_empty() {
        len
    } else {
        let last = num(b)?;
        if last < start {
            return None;
        }
        last.min(len - 1) + 1
    };
    Some((start, end))
}

fn content_type(p: &Path) -> &'static str {
    match p.extension().and_then(|e| e.to_str()).unwrap_or("") {
        "html" => "text/html; charset=utf-8",
        "js" | "mjs" => "text/javascript; charset=utf-8",
        "css" => "text/css; charset=utf-8",
        "json" | "map" => "application/json",
        "wgsl" | "txt" | "md" | "ron" => "text/plain; charset=utf-8",
        "png" => "image/png",
        _ => "application/octet-stream",
    }
}

fn respond(out: &mut TcpStream, req: &Request, roots: &Roots) -> std::io::Result<()> {
    let head_only = match req.method.as_str() {
        "GET" => false,
        "HEAD" => true,
        _ => return error_response(out, 405, req.close),
    };
    let target = match resolve(&req.target, roots) {
        Ok(t) => t,
        Err(code) => return error_response(out, code, req.close),
    };
    let path = match target {
        Target::Shader => {
            let body = shader_source();
            write_head(
                out,
                200,
                "OK",
                &[("Content-Type", "text/plain; charset=utf-8".into())],
                body.len() as u64,
                req.close,
            )?;
            if !head_only {
                out.write_all(body.as_bytes())?;
            }
            return out.flush();
        }
        Target::File(p) => p,
    };
    let root = if path.starts_with(&roots.bake) {
        &roots.bake
    } else {
        &roots.web
    };
    let path = match path.canonicalize() {
        Ok(p) => p,
        Err(_) if root == &roots.bake && roots.derive => {
            return match derived(&path, root) {
                Some(Ok((bytes, immutable))) => serve_bytes(out, req, &bytes, immutable, head_only),
                Some(Err((code, why))) => {
                    eprintln!("pipeline serve: {}: {why}", req.target);
                    error_response(out, code, req.close)
                }
                None => error_response(out, 404, req.close),
            };
        }
        Err(_) => return error_response(out, 404, req.close),
    };
    if !path.starts_with(root) {
        return error_response(out, 403, req.close);
    }
    let path = if path.is_dir() {
        path.join("index.html")
    } else {
        path
    };
    let mut file = match File::open(&path) {
        Ok(f) if f.metadata().map(|m| m.is_file()).unwrap_or(false) => f,
        _ => return error_response(out, 404, req.close),
    };
    let len = match file.metadata() {
        Ok(m) => m.len(),
        Err(_) => return error_response(out, 500, req.close),
    };
    let ctype = ("Content-Type", content_type(&path).to_string());
    let ranges = ("Accept-Ranges", "bytes".to_string());
    let (code, start, end) = match &req.range {
        None => (200, 0, len),
        Some(r) => match parse_range(r, len) {
            Some((s, e)) => (206, s, e),
            None => {
                write_head(
                    out,
                    416,
                    reason(416),
                    &[ranges, ("Content-Range", format!("bytes */{len}"))],
                    0,
                    req.close,
                )?;
                return out.flush();
            }
        },
    };
    let mut headers = vec![ctype, ranges];
    if immutable(&path) {
        headers.push(("Cache-Control", IMMUTABLE.to_string()));
    }
    if code == 206 {
        headers.push(("Content-Range", format!("bytes {start}-{}/{len}", end - 1)));
    }
    write_head(out, code, reason(code), &headers, end - start, req.close)?;
    if !head_only {
        file.seek(SeekFrom::Start(start))?;
        let copied = std::io::copy(&mut (&mut file).take(end - start), out)?;
        if copied != end - start {
            // The file shrank under us: the promised length cannot be kept.
            return Err(std::io::Error::other("file shrank while being served"));
        }
    }
    out.flush()
}

/// `pipeline web-export` arguments.
#[derive(clap::Args, Debug, Clone)]
pub struct WebExportArgs {
    /// The bake folder: writes `<pack>.vertices` and `<pack>.textures` beside every
    /// cell and group pack its `index.pack` lists.
    pub out: PathBuf,
}

/// Writes every derived file of a bake for a static host (format/README.md
/// "Derived files for the browser"), each as one zstd frame of its bytes (level
/// [`DERIVED_ZSTD_LEVEL`]; the viewer decodes a frame it finds), atomically. Returns
/// the files written and their bytes. `pipeline serve` serves these as they are.
pub fn web_export(args: &WebExportArgs) -> anyhow::Result<(usize, u64)> {
    use format::pack::web;
    use rayon::prelude::*;
    let bake = &args.out;
    let index = format::pack::Index::read(&bake.join("index.pack"))?;
    let base = index.read_base(bake)?;
    let files: Vec<&str> = index
        .cells
        .iter()
        .chain(&index.groups)
        .map(|e| e.file.as_str())
        .collect();
    let written = files
        .par_iter()
        .map(|file| -> anyhow::Result<u64> {
            let path = bake.join(file);
            let pack = format::pack::PackFile::open(&path)?;
            let mut bytes = 0;
            for (suffix, data) in [
                (web::VERTICES_SUFFIX, web::vertices_file(&base, &pack)?),
                (web::TEXTURES_SUFFIX, web::textures_file(&pack, bake)?),
            ] {
                let frame = zstd::bulk::compress(&data, DERIVED_ZSTD_LEVEL)?;
                format::pack::write_atomic(&bake.join(format!("{file}{suffix}")), &frame)?;
                bytes += frame.len() as u64;
            }
            Ok(bytes)
        })
        .collect::<anyhow::Result<Vec<u64>>>()?;
    Ok((2 * written.len(), written.iter().sum()))
}

/// zstd level of derived files sent compressed: on park-2m cell 253's 1.79 MB of
/// textures, level 3 gives 704 KB in 20 ms, 6 gives 690 KB in 30 ms, 9 689 KB in 70 ms.
const DERIVED_ZSTD_LEVEL: i32 = 6;

/// A derived file's bytes and whether its pack's name is its content.
type Derived = (Vec<u8>, bool);

/// A derived file's bytes (format/README.md "Derived files for the browser"):
/// `<pack>.vertices` or `<pack>.textures` beside a cell or group pack that exists,
/// when the bake folder does not hold that file itself (`pipeline web-export` writes
/// them for static hosts). `None`: not such a name, or no such pack (`404`); an error:
/// the status and why. The flag says whether the pack's name is its content.
fn derived(path: &Path, bake: &Path) -> Option<Result<Derived, (u16, String)>> {
    use format::pack::web;
    let name = path.file_name()?.to_str()?;
    let (stem, textures) = if let Some(s) = name.strip_suffix(web::VERTICES_SUFFIX) {
        (s, false)
    } else {
        (name.strip_suffix(web::TEXTURES_SUFFIX)?, true)
    };
    if !stem.ends_with(".pack") {
        return None;
    }
    let pack_path = path.with_file_name(stem).canonicalize().ok()?;
    let dir = pack_path.parent()?;
    let in_bake = dir.parent() == Some(bake)
        && matches!(dir.file_name()?.to_str()?, "cells" | "groups")
        && pack_path.is_file();
    if !in_bake {
        return None;
    }
    let immutable = format::pack::generation::is_published_file_name(stem);
    let fail = |e: String| (500u16, e);
    let bytes = (|| {
        let pack = format::pack::PackFile::open(&pack_path).map_err(|e| fail(e.to_string()))?;
        if textures {
            web::textures_file(&pack, bake).map_err(|e| fail(e.to_string()))
        } else {
            let base = cached_base(bake).map_err(fail)?;
            web::vertices_file(&base, &pack).map_err(|e| fail(e.to_string()))
        }
    })();
    Some(bytes.map(|b| (b, immutable)))
}

/// The base pack the bake's `index.pack` names, decoded once per index generation
/// (the index's length and modification time key the cache).
fn cached_base(bake: &Path) -> Result<Arc<format::pack::BasePack>, String> {
    type Key = (PathBuf, u64, Option<std::time::SystemTime>);
    static CACHE: std::sync::Mutex<Option<(Key, Arc<format::pack::BasePack>)>> =
        std::sync::Mutex::new(None);
    let index_path = bake.join("index.pack");
    let meta =
        std::fs::metadata(&index_path).map_err(|e| format!("{}: {e}", index_path.display()))?;
    let key = (bake.to_path_buf(), meta.len(), meta.modified().ok());
    let mut cache = CACHE.lock().unwrap_or_else(|p| p.into_inner());
    if let Some((k, base)) = cache.as_ref() {
        if *k == key {
            return Ok(base.clone());
        }
    }
    let index = format::pack::Index::read(&index_path).map_err(|e| e.to_string())?;
    let base = Arc::new(index.read_base(bake).map_err(|e| e.to_string())?);
    *cache = Some((key, base.clone()));
    Ok(base)
}

/// Answers with `bytes` whole (a `Range` is ignored: `200` with everything is a valid
/// answer to one), as one zstd frame (`Content-Encoding: zstd`, level
/// [`DERIVED_ZSTD_LEVEL`]) when the client accepts that.
fn serve_bytes(
    out: &mut TcpStream,
    req: &Request,
    bytes: &[u8],
    immutable: bool,
    head_only: bool,
) -> std::io::Result<()> {
    let mut headers = vec![
        ("Content-Type", "application/octet-stream".to_string()),
        ("Vary", "Accept-Encoding".to_string()),
    ];
    if immutable {
        headers.push(("Cache-Control", IMMUTABLE.to_string()));
    }
    let packed;
    let bytes = if req.zstd {
        packed = zstd::bulk::compress(bytes, DERIVED_ZSTD_LEVEL)?;
        headers.push(("Content-Encoding", "zstd".to_string()));
        &packed[..]
    } else {
        bytes
    };
    write_head(out, 200, "OK", &headers, bytes.len() as u64, req.close)?;
    if !head_only {
        out.write_all(bytes)?;
    }
    out.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_parse() {
        assert_eq!(parse_range("bytes=0-9", 100), Some((0, 10)));
        assert_eq!(parse_range("bytes=90-", 100), Some((90, 100)));
        assert_eq!(parse_range("bytes=90-1000", 100), Some((90, 100)));
        assert_eq!(parse_range("bytes=-10", 100), Some((90, 100)));
        assert_eq!(parse_range("bytes=-1000", 100), Some((0, 100)));
        assert_eq!(parse_range(" bytes=5-5 ", 100), Some((5, 6)));
        assert_eq!(parse_range("bytes=99-99", 100), Some((99, 100)));
    }

    #[test]
    fn bad_ranges_are_refused() {
        for r in [
            "bytes=100-",
            "bytes=100-200",
            "bytes=5-4",
            "bytes=-0",
            "bytes=-",
            "bytes=a-b",
            "bytes=1-2,4-5",
            "items=0-1",
            "bytes=0x1-2",
            "bytes=+1-2",
            "bytes=99999999999999999999999-",
            "",
        ] {
            assert_eq!(parse_range(r, 100), None, "{r}");
        }
        assert_eq!(parse_range("bytes=0-", 0), None);
        assert_eq!(parse_range("bytes=-5", 0), None);
    }

    fn roots() -> Roots {
        Roots {
            bake: PathBuf::from("/srv/bake"),
            web: PathBuf::from("/srv/web"),
            derive: true,
        }
    }

    #[test]
    fn targets_map_into_their_folders() {
        let r = roots();
        assert_eq!(
            resolve("/bake/cells/3.pack", &r),
            Ok(Target::File("/srv/bake/cells/3.pack".into()))
        );
        assert_eq!(
            resolve("/dist/viewer.js?x=1", &r),
            Ok(Target::File("/srv/web/dist/viewer.js".into()))
        );
        assert_eq!(resolve("/", &r), Ok(Target::File("/srv/web".into())));
        assert_eq!(resolve("/shader.wgsl", &r), Ok(Target::Shader));
        assert_eq!(
            resolve("/bake/a%20b", &r),
            Ok(Target::File("/srv/bake/a b".into()))
        );
    }

    #[test]
    fn escapes_are_refused() {
        let r = roots();
        for t in [
            "/bake/../secret",
            "/../etc/passwd",
            "/bake/%2e%2e/x",
            "/bake/%2E%2E/x",
            "/bake/cells/..",
            "/bake/./index.pack",
            "/bake/a%2fb",
            "/bake/a%5cb",
            "/bake/a%00b",
            "/bake/%zz",
            "/bake/%",
            "/bake/%ff",
        ] {
            assert_eq!(resolve(t, &r), Err(403), "{t}");
        }
        assert_eq!(resolve("bake/x", &r), Err(400));
        assert_eq!(resolve("http://h/x", &r), Err(400));
    }

    #[test]
    fn request_heads_parse_and_bad_ones_are_refused() {
        let mut ok = &b"GET /bake/index.pack HTTP/1.1\r\nHost: x\r\nRange: bytes=0-63\r\n\r\n"[..];
        let req = read_request(&mut ok).unwrap().unwrap();
        assert_eq!(req.target, "/bake/index.pack");
        assert_eq!(req.range.as_deref(), Some("bytes=0-63"));
        assert!(!req.close);
        let mut old = &b"GET / HTTP/1.0\r\n\r\n"[..];
        assert!(read_request(&mut old).unwrap().unwrap().close);
        let mut empty = &b""[..];
        assert_eq!(read_request(&mut empty), Ok(None));
        for bad in [
            &b"GET /\r\n\r\n"[..],
            b"GET / HTTP/1.1",
            b"GET / HTTP/1.1\r\nno colon\r\n\r\n",
            b"GET  / HTTP/1.1\r\n\r\n",
            b"\xff\xfe / HTTP/1.1\r\n\r\n",
        ] {
            let mut r = bad;
            assert!(read_request(&mut r).is_err(), "{bad:?}");
        }
        let mut v2 = &b"GET / HTTP/2.0\r\n\r\n"[..];
        assert_eq!(read_request(&mut v2), Err(505));
        let long = format!("GET / HTTP/1.1\r\nX: {}\r\n\r\n", "a".repeat(MAX_HEAD));
        assert_eq!(read_request(&mut long.as_bytes()), Err(431));
    }

    /// A real server on a free port: status codes and bytes of range requests, and a
    /// link out of the bake refused.
    #[test]
    fn serves_ranges_over_tcp() {
        let dir = tempfile::tempdir().unwrap();
        let bake = dir.path().join("bake");
        let web = dir.path().join("web");
        std::fs::create_dir_all(bake.join("cells")).unwrap();
        std::fs::create_dir_all(&web).unwrap();
        let data: Vec<u8> = (0..200u32).map(|i| i as u8).collect();
        std::fs::write(bake.join("cells/1.pack"), &data).unwrap();
        std::fs::write(dir.path().join("secret"), b"no").unwrap();
        std::os::unix::fs::symlink(dir.path().join("secret"), bake.join("link")).unwrap();
        std::fs::write(web.join("index.html"), b"<p>hi</p>").unwrap();
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap();
        let roots = Roots {
            bake: bake.canonicalize().unwrap(),
            web: web.canonicalize().unwrap(),
            derive: true,
        };
        std::thread::spawn(move || run_listener(listener, roots));
        let get = |req: &str| -> Vec<u8> {
            let mut s = TcpStream::connect(addr).unwrap();
            s.write_all(req.as_bytes()).unwrap();
            let mut v = Vec::new();
            s.read_to_end(&mut v).unwrap();
            v
        };
        let split = |v: &[u8]| -> (String, Vec<u8>) {
            let at = v.windows(4).position(|w| w == b"\r\n\r\n").unwrap();
            (
                String::from_utf8(v[..at].to_vec()).unwrap(),
                v[at + 4..].to_vec(),
            )
        };
        let close = "Connection: close\r\n\r\n";
        let (h, b) = split(&get(&format!(
            "GET /bake/cells/1.pack HTTP/1.1\r\nRange: bytes=10-19\r\n{close}"
        )));
        assert!(h.starts_with("HTTP/1.1 206"), "{h}");
        assert!(h.contains("Content-Range: bytes 10-19/200"), "{h}");
        assert!(h.contains("Cache-Control: no-cache"), "a working file: {h}");
        assert_eq!(b, &data[10..20]);
        // A published pack is immutable (its name is its content, issue 32).
        std::fs::write(bake.join("cells/1-0123456789abcdef.pack"), &data).unwrap();
        let (h, _) = split(&get(&format!(
            "GET /bake/cells/1-0123456789abcdef.pack HTTP/1.1\r\n{close}"
        )));
        assert!(h.starts_with("HTTP/1.1 200"), "{h}");
        assert!(
            h.contains("Cache-Control: public, max-age=31536000, immutable"),
            "{h}"
        );
        assert_eq!(h.matches("Cache-Control").count(), 1, "{h}");
        let (h, b) = split(&get(&format!("GET /bake/cells/1.pack HTTP/1.1\r\n{close}")));
        assert!(h.starts_with("HTTP/1.1 200"), "{h}");
        assert_eq!(b, data);
        let (h, _) = split(&get(&format!(
            "GET /bake/cells/1.pack HTTP/1.1\r\nRange: bytes=500-\r\n{close}"
        )));
        assert!(h.starts_with("HTTP/1.1 416"), "{h}");
        assert!(h.contains("Content-Range: bytes */200"), "{h}");
        for (t, code) in [
            ("/bake/../secret", "403"),
            ("/bake/link", "403"),
            ("/bake/nothing.pack", "404"),
            ("/bake/cells", "404"),
        ] {
            let (h, _) = split(&get(&format!("GET {t} HTTP/1.1\r\n{close}")));
            assert!(h.starts_with(&format!("HTTP/1.1 {code}")), "{t}: {h}");
        }
        let (h, b) = split(&get(&format!("GET / HTTP/1.1\r\n{close}")));
        assert!(h.contains("text/html"), "{h}");
        assert_eq!(b, b"<p>hi</p>");
        let (h, b) = split(&get(&format!("HEAD /shader.wgsl HTTP/1.1\r\n{close}")));
        assert!(h.starts_with("HTTP/1.1 200"), "{h}");
        assert!(b.is_empty());
        let (h, _) = split(&get(&format!("POST / HTTP/1.1\r\n{close}")));
        assert!(h.starts_with("HTTP/1.1 405"), "{h}");
        let (h, _) = split(&get("garbage\r\n\r\n"));
        assert!(h.starts_with("HTTP/1.1 400"), "{h}");
        // Keep-alive: two requests on one connection.
        let two = get(&format!(
            "GET /bake/cells/1.pack HTTP/1.1\r\nRange: bytes=0-0\r\n\r\nGET /bake/cells/1.pack HTTP/1.1\r\nRange: bytes=1-1\r\n{close}"
        ));
        assert_eq!(
            String::from_utf8_lossy(&two)
                .matches("HTTP/1.1 206")
                .count(),
            2
        );
        // The server still answers after all of that.
        let (h, _) = split(&get(&format!("GET / HTTP/1.1\r\n{close}")));
        assert!(h.starts_with("HTTP/1.1 200"), "{h}");
    }

    /// `<pack>.vertices` and `<pack>.textures`: derived from a real pack, its base
    /// and its store, zstd-encoded only for a client that accepts it, and absent
    /// (404) under `--static`, for a pack that does not exist, or outside
    /// `cells/`/`groups/`.
    #[test]
    fn derived_files_are_served_beside_packs() {
        use format::pack::{sample, web};
        let dir = tempfile::tempdir().unwrap();
        let bake = dir.path().join("bake");
        std::fs::create_dir_all(bake.join("cells")).unwrap();
        let web_dir = dir.path().join("web");
        std::fs::create_dir_all(&web_dir).unwrap();
        let base = sample::small_base();
        base.write(&bake.join("base.pack")).unwrap();
        sample::small_index()
            .write(&bake.join("index.pack"))
            .unwrap();
        let cell = sample::small_cell();
        let pack_bytes = cell.encode_reusing(false, None, Some(&bake)).unwrap();
        std::fs::write(bake.join("cells/1.pack"), &pack_bytes).unwrap();
        std::fs::write(bake.join("stray.pack"), &pack_bytes).unwrap();
        let pack = format::pack::PackFile::open(&bake.join("cells/1.pack")).unwrap();
        let want_v = web::vertices_file(&base, &pack).unwrap();
        let want_t = web::textures_file(&pack, &bake).unwrap();
        let serve = |derive: bool| {
            let listener = TcpListener::bind("127.0.0.1:0").unwrap();
            let addr = listener.local_addr().unwrap();
            let roots = Roots {
                bake: bake.canonicalize().unwrap(),
                web: web_dir.canonicalize().unwrap(),
                derive,
            };
            std::thread::spawn(move || run_listener(listener, roots));
            addr
        };
        let get = |addr: std::net::SocketAddr, target: &str, zstd: bool| -> (String, Vec<u8>) {
            let mut s = TcpStream::connect(addr).unwrap();
            let enc = if zstd {
                "Accept-Encoding: gzip, zstd\r\n"
            } else {
                ""
            };
            s.write_all(
                format!("GET {target} HTTP/1.1\r\n{enc}Connection: close\r\n\r\n").as_bytes(),
            )
            .unwrap();
            let mut v = Vec::new();
            s.read_to_end(&mut v).unwrap();
            let at = v.windows(4).position(|w| w == b"\r\n\r\n").unwrap();
            (
                String::from_utf8(v[..at].to_vec()).unwrap(),
                v[at + 4..].to_vec(),
            )
        };
        let on = serve(true);
        let (h, b) = get(on, "/bake/cells/1.pack.vertices", false);
        assert!(
            h.starts_with("HTTP/1.1 200") && !h.contains("Content-Encoding"),
            "{h}"
        );
        assert_eq!(b, want_v);
        let (h, b) = get(on, "/bake/cells/1.pack.textures", true);
        assert!(h.contains("Content-Encoding: zstd"), "{h}");
        assert_eq!(zstd::decode_all(&b[..]).unwrap(), want_t);
        assert!(!web::decode_textures(&want_t, Path::new("t"))
            .unwrap()
            .is_empty());
        for t in [
            "/bake/cells/2.pack.vertices",
            "/bake/stray.pack.vertices",
            "/bake/cells/1.pack.other",
            "/bake/index.pack.textures",
        ] {
            let (h, _) = get(on, t, false);
            assert!(h.starts_with("HTTP/1.1 404"), "{t}: {h}");
        }
        let off = serve(false);
        let (h, _) = get(off, "/bake/cells/1.pack.vertices", false);
        assert!(h.starts_with("HTTP/1.1 404"), "--static: {h}");
        let (h, b) = get(off, "/bake/cells/1.pack", false);
        assert!(h.starts_with("HTTP/1.1 200"), "{h}");
        assert_eq!(b, pack_bytes);
    }
}
