//! C ABI over the scatterbake table reader, for C/C++ renderers (header
//! `c/scatterbake_table.h`, example `c/example.c`). Built as `libscatterbake_table.so` /
//! `.dylib` / `scatterbake_table.dll` by `cargo build -p scatterbake-capi --release`. It depends on
//! the table format crate (`scatterbake-table`, `table-format/`) alone, not on the library that
//! computes tables.
//!
//! `sbt_open` fully verifies the file (magic, version, header SHA-256, payload SHA-256 of the
//! compressed and uncompressed bytes, sizes) with the same code as `Table::open`, and
//! `sbt_open_slice` as `Table::open_slice`, keeping one entry; every other call reads the
//! verified table. The samples are allocated fallibly: running out of memory is an error from
//! the open call, not an abort of the host. All pointers returned stay valid until `sbt_close`. Functions
//! taking an out-of-range index return 0 / NULL / NaN rather than aborting. Every entry point
//! runs under `catch_unwind`: an internal panic never unwinds into the host; `sbt_open` then
//! returns NULL with a message and the other calls return their error value.

use std::ffi::{CStr, CString, c_char};
use std::panic::{AssertUnwindSafe, catch_unwind};
use table::{ReadLimits, Table};

/// Run `f`, turning a panic into `on_panic` (never unwinding across the C boundary).
fn guard<T>(on_panic: T, f: impl FnOnce() -> T) -> T {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or(on_panic)
}

/// Opaque handle behind `sbt_table *`.
pub struct SbtTable {
    table: Table,
    header_json: CString,
    axis_names: Vec<CString>,
    axis_units: Vec<CString>,
    axis_coords: Vec<Vec<f64>>,
    channel_names: Vec<CString>,
    channel_units: Vec<CString>,
}

fn cstring(s: &str) -> CString {
    CString::new(s.replace('\0', " ")).expect("no interior NUL")
}

fn write_err(err: *mut c_char, err_len: usize, msg: &str) {
    if err.is_null() || err_len == 0 {
        return;
    }
    let bytes = msg.as_bytes();
    let n = bytes.len().min(err_len - 1);
    // SAFETY: the caller guarantees `err` points to `err_len` writable bytes.
    unsafe {
        std::ptr::copy_nonoverlapping(bytes.as_ptr(), err.cast::<u8>(), n);
        *err.add(n) = 0;
    }
}

/// Open and verify a table with the default payload limit (4 GiB uncompressed). Returns NULL on
/// failure with a message in `err` (if not NULL).
///
/// # Safety
/// `path` must be a NUL-terminated string; `err` NULL or `err_len` writable bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sbt_open(
    path: *const c_char,
    err: *mut c_char,
    err_len: usize,
) -> *mut SbtTable {
    // SAFETY: same contract.
    unsafe { sbt_open_limit(path, 0, err, err_len) }
}

/// Like `sbt_open`, refusing tables whose uncompressed payload exceeds `max_payload_bytes`
/// (0 = the default limit).
///
/// # Safety
/// `path` must be a NUL-terminated string; `err` NULL or `err_len` writable bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sbt_open_limit(
    path: *const c_char,
    max_payload_bytes: u64,
    err: *mut c_char,
    err_len: usize,
) -> *mut SbtTable {
    // SAFETY: forwarded contract.
    unsafe { open_boxed(path, max_payload_bytes, Mode::Whole, err, err_len) }
}

/// Like `sbt_open_limit`, but a tensor-train table (`fur-medulla-tt/1`, e.g. the shipped
/// `assets/fur-medulla/*.sbt`) is checked and reconstructed into the dense table it holds
/// (`Table::open_reconstructed`; the limit also bounds the reconstruction); any other table is
/// opened as by `sbt_open_limit`.
///
/// # Safety
/// `path` must be a NUL-terminated string; `err` NULL or `err_len` writable bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sbt_open_reconstructed(
    path: *const c_char,
    max_payload_bytes: u64,
    err: *mut c_char,
    err_len: usize,
) -> *mut SbtTable {
    // SAFETY: forwarded contract.
    unsafe { open_boxed(path, max_payload_bytes, Mode::Reconstruct, err, err_len) }
}

/// Open one entry of a table: `entry[0 .. n_entry)` fixes the first `n_entry` axes at these
/// indices (`Table::open_slice`). Every checksum is verified over the whole payload while it
/// streams past; only the entry's samples are kept. The table keeps every axis, a fixed one
/// with its chosen coordinate alone (length 1). NULL on failure (bad file, more indices than
/// axes, an index beyond its axis, memory) with a message in `err`.
///
/// # Safety
/// `path` must be a NUL-terminated string; `entry` NULL (with `n_entry` 0) or `n_entry`
/// readable `size_t`; `err` NULL or `err_len` writable bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sbt_open_slice(
    path: *const c_char,
    entry: *const usize,
    n_entry: usize,
    err: *mut c_char,
    err_len: usize,
) -> *mut SbtTable {
    // SAFETY: same contract.
    unsafe { sbt_open_slice_limit(path, entry, n_entry, 0, err, err_len) }
}

/// Like `sbt_open_slice`, refusing tables whose whole uncompressed payload exceeds
/// `max_payload_bytes` (0 = the default limit).
///
/// # Safety
/// As `sbt_open_slice`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sbt_open_slice_limit(
    path: *const c_char,
    entry: *const usize,
    n_entry: usize,
    max_payload_bytes: u64,
    err: *mut c_char,
    err_len: usize,
) -> *mut SbtTable {
    if entry.is_null() && n_entry > 0 {
        write_err(err, err_len, "entry is NULL with a non-zero count");
        return std::ptr::null_mut();
    }
    let entry = if n_entry == 0 {
        &[][..]
    } else {
        // SAFETY: `n_entry` readable values per the contract.
        unsafe { std::slice::from_raw_parts(entry, n_entry) }
    };
    // SAFETY: forwarded contract.
    unsafe { open_boxed(path, max_payload_bytes, Mode::Entry(entry), err, err_len) }
}

/// How a table is opened.
#[derive(Debug, Clone, Copy)]
enum Mode<'a> {
    /// Every sample.
    Whole,
    /// A tensor-train table reconstructed into its dense table.
    Reconstruct,
    /// The entry at these indices of the first axes.
    Entry(&'a [usize]),
}

/// Open as `mode` says behind `catch_unwind`: a boxed table, or NULL with the message written to
/// `err`.
///
/// # Safety
/// As `sbt_open_limit`.
unsafe fn open_boxed(
    path: *const c_char,
    max_payload_bytes: u64,
    mode: Mode<'_>,
    err: *mut c_char,
    err_len: usize,
) -> *mut SbtTable {
    let r = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: forwarded contract.
        unsafe { open_table(path, max_payload_bytes, mode) }
    }));
    match r {
        Ok(Ok(t)) => Box::into_raw(Box::new(t)),
        Ok(Err(msg)) => {
            write_err(err, err_len, &msg);
            std::ptr::null_mut()
        }
        Err(_) => {
            write_err(
                err,
                err_len,
                "internal error while reading the table (panic caught)",
            );
            std::ptr::null_mut()
        }
    }
}

unsafe fn open_table(
    path: *const c_char,
    max_payload_bytes: u64,
    mode: Mode<'_>,
) -> Result<SbtTable, String> {
    if path.is_null() {
        return Err("path is NULL".into());
    }
    // SAFETY: NUL-terminated per the contract.
    let p = unsafe { CStr::from_ptr(path) }
        .to_string_lossy()
        .into_owned();
    let mut limits = ReadLimits::default();
    if max_payload_bytes != 0 {
        limits.max_payload_bytes = max_payload_bytes;
    }
    let table = match mode {
        Mode::Whole => Table::open_with_limits(&p, &limits),
        Mode::Reconstruct => Table::open_reconstructed(&p, &limits),
        Mode::Entry(entry) => Table::open_slice(&p, entry, &limits),
    }
    .map_err(|e| e.to_string())?;
    let header_json = cstring(&serde_json::to_string(&table.header).unwrap_or_default());
    let h = &table.header;
    Ok(SbtTable {
        header_json,
        axis_names: h.axes.iter().map(|a| cstring(&a.name)).collect(),
        axis_units: h.axes.iter().map(|a| cstring(&a.unit)).collect(),
        axis_coords: h.axes.iter().map(|a| a.coords()).collect(),
        channel_names: h.channels.iter().map(|c| cstring(&c.name)).collect(),
        channel_units: h.channels.iter().map(|c| cstring(&c.unit)).collect(),
        table,
    })
}

/// Free a table (NULL is ignored).
///
/// # Safety
/// `t` must come from `sbt_open` and not be used afterwards.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sbt_close(t: *mut SbtTable) {
    if !t.is_null() {
        guard((), || {
            // SAFETY: allocated by Box::into_raw in sbt_open.
            drop(unsafe { Box::from_raw(t) });
        });
    }
}

fn get<'a>(t: *const SbtTable) -> Option<&'a SbtTable> {
    // SAFETY: callers pass NULL or a live handle from sbt_open.
    unsafe { t.as_ref() }
}

fn ptr_or_null(v: Option<&CString>) -> *const c_char {
    v.map(|s| s.as_ptr()).unwrap_or(std::ptr::null())
}

/// The verified JSON header (NUL-terminated), re-serialised: fields a newer minor version adds
/// are not included.
///
/// # Safety
/// `t` must be NULL or a live handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sbt_header_json(t: *const SbtTable) -> *const c_char {
    guard(std::ptr::null(), || {
        ptr_or_null(get(t).map(|t| &t.header_json))
    })
}

/// Number of axes.
///
/// # Safety
/// `t` must be NULL or a live handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sbt_num_axes(t: *const SbtTable) -> usize {
    guard(0, || get(t).map_or(0, |t| t.axis_names.len()))
}

/// Name of axis `a`.
///
/// # Safety
/// `t` must be NULL or a live handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sbt_axis_name(t: *const SbtTable, a: usize) -> *const c_char {
    guard(std::ptr::null(), || {
        ptr_or_null(get(t).and_then(|t| t.axis_names.get(a)))
    })
}

/// Unit of axis `a`.
///
/// # Safety
/// `t` must be NULL or a live handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sbt_axis_unit(t: *const SbtTable, a: usize) -> *const c_char {
    guard(std::ptr::null(), || {
        ptr_or_null(get(t).and_then(|t| t.axis_units.get(a)))
    })
}

/// Number of samples of axis `a`.
///
/// # Safety
/// `t` must be NULL or a live handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sbt_axis_len(t: *const SbtTable, a: usize) -> usize {
    guard(0, || {
        get(t)
            .and_then(|t| t.axis_coords.get(a))
            .map_or(0, |c| c.len())
    })
}

/// Pointer to the `sbt_axis_len(t, a)` coordinates of axis `a` (doubles).
///
/// # Safety
/// `t` must be NULL or a live handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sbt_axis_coords(t: *const SbtTable, a: usize) -> *const f64 {
    guard(std::ptr::null(), || {
        get(t)
            .and_then(|t| t.axis_coords.get(a))
            .map_or(std::ptr::null(), |c| c.as_ptr())
    })
}

/// Period of axis `a` when it is even-periodic (format 3.0: it stores 0 … period/2 and
/// `sbt_sample` folds its coordinate), 0 for any other axis or an index out of range.
///
/// # Safety
/// `t` must be NULL or a live handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sbt_axis_period(t: *const SbtTable, a: usize) -> f64 {
    guard(0.0, || {
        get(t)
            .and_then(|t| t.table.header.axes.get(a))
            .and_then(|a| a.symmetry)
            .map_or(0.0, |s| s.period())
    })
}

/// Number of channels.
///
/// # Safety
/// `t` must be NULL or a live handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sbt_num_channels(t: *const SbtTable) -> usize {
    guard(0, || get(t).map_or(0, |t| t.channel_names.len()))
}

/// Name of channel `c`.
///
/// # Safety
/// `t` must be NULL or a live handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sbt_channel_name(t: *const SbtTable, c: usize) -> *const c_char {
    guard(std::ptr::null(), || {
        ptr_or_null(get(t).and_then(|t| t.channel_names.get(c)))
    })
}

/// Unit of channel `c`.
///
/// # Safety
/// `t` must be NULL or a live handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sbt_channel_unit(t: *const SbtTable, c: usize) -> *const c_char {
    guard(std::ptr::null(), || {
        ptr_or_null(get(t).and_then(|t| t.channel_units.get(c)))
    })
}

/// The samples: row-major, axes in order, channel innermost (`sbt_data_len` floats).
///
/// # Safety
/// `t` must be NULL or a live handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sbt_data(t: *const SbtTable) -> *const f32 {
    guard(std::ptr::null(), || {
        get(t).map_or(std::ptr::null(), |t| t.table.data.as_ptr())
    })
}

/// Number of floats behind `sbt_data`.
///
/// # Safety
/// `t` must be NULL or a live handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sbt_data_len(t: *const SbtTable) -> usize {
    guard(0, || get(t).map_or(0, |t| t.table.data.len()))
}

/// Multilinear lookup of every channel at `coords` (one per axis, axis units; folded on an
/// even-periodic axis, then clamped at the axis ends), written to `out` (`n_out` ≥ number of
/// channels). Returns 0 on success, −1 on bad arguments (wrong arity, NaN, an infinite
/// coordinate of an even-periodic axis, NULL, short `out`).
///
/// # Safety
/// `t` NULL or live; `coords` `n_coords` readable doubles; `out` `n_out` writable doubles.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sbt_sample(
    t: *const SbtTable,
    coords: *const f64,
    n_coords: usize,
    out: *mut f64,
    n_out: usize,
) -> i32 {
    guard(-1, || {
        let Some(t) = get(t) else { return -1 };
        if coords.is_null() || out.is_null() || n_out < t.channel_names.len() {
            return -1;
        }
        // SAFETY: sizes per the contract above.
        let c = unsafe { std::slice::from_raw_parts(coords, n_coords) };
        match t.table.sample(c) {
            Ok(v) => {
                // SAFETY: n_out ≥ v.len() checked above.
                let o = unsafe { std::slice::from_raw_parts_mut(out, v.len()) };
                o.copy_from_slice(&v);
                0
            }
            Err(_) => -1,
        }
    })
}
