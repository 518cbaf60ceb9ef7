//! What the PLY tests share: a file split at its header, and the header's element counts.

/// The header (through `end_header\n`) and the body of a PLY file.
pub(crate) fn split_ply(bytes: &[u8]) -> Result<(&str, &[u8]), String> {
    const END: &[u8] = b"end_header\n";
    let end = bytes
        .windows(END.len())
        .position(|w| w == END)
        .ok_or("no end_header")?
        + END.len();
    let header = std::str::from_utf8(&bytes[..end]).map_err(|e| e.to_string())?;
    Ok((header, &bytes[end..]))
}

/// The count of `element` the header declares.
pub(crate) fn element_count(header: &str, element: &str) -> Result<usize, String> {
    header
        .lines()
        .find_map(|l| l.strip_prefix(&format!("element {element} ")))
        .ok_or(format!("no element {element}"))?
        .parse()
        .map_err(|e| format!("element {element}: {e}"))
}
