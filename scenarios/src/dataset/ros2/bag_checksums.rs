//! A bag's checksums, checked as the MCAP readers that check them do (Foxglove's): each
//! chunk's CRC of its records, the data section's and the summary section's. A mismatch (or a
//! chunk that does not decompress) names the chunk: its ordinal, byte offset and length.

use mcap::McapError;
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};

/// MCAP's opcodes of the records the walk looks at.
const OP_CHUNK: u8 = 0x06;
const OP_DATA_END: u8 = 0x0F;
/// The magic bytes at the start of the file.
const MAGIC_LEN: usize = 8;

/// `(offset, length)` of each chunk record at the top level of the data section, in file order:
/// a walk over the record headers (opcode, length), ending at the data end record or at the first
/// header that does not fit the file.
fn chunk_spans(bytes: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut at = MAGIC_LEN;
    while let Some(header) = bytes.get(at..at + 9) {
        let op = header[0];
        let len = u64::from_le_bytes(header[1..9].try_into().expect("8 bytes"));
        let Some(end) = usize::try_from(len)
            .ok()
            .and_then(|l| (at + 9).checked_add(l))
            .filter(|&e| e <= bytes.len())
        else {
            break;
        };
        if op == OP_CHUNK {
            spans.push((at, end - at));
        }
        if op == OP_DATA_END {
            break;
        }
        at = end;
    }
    spans
}

/// The chunk the reader was in when it failed, having read `pos` bytes: the last chunk that
/// starts before `pos`.
fn chunk_at(bytes: &[u8], pos: usize) -> Option<(usize, (usize, usize))> {
    chunk_spans(bytes)
        .into_iter()
        .enumerate()
        .rev()
        .find(|(_, (offset, _))| *offset < pos)
}

/// Reads `bytes` through checking every chunk's CRC (after decompressing it), the data
/// section's CRC and the summary section's (each where the writer stored one: a CRC of 0 means
/// none). The error says what failed and where.
pub fn check(bytes: &[u8]) -> Result<(), String> {
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_validate_chunk_crcs(true)
            .with_validate_data_section_crc(true)
            .with_validate_summary_section_crc(true),
    );
    let mut pos = 0usize;
    while let Some(event) = reader.next_event() {
        match event {
            Ok(LinearReadEvent::ReadRequest(n)) => {
                let n = n.min(bytes.len() - pos);
                reader.insert(n).copy_from_slice(&bytes[pos..pos + n]);
                reader.notify_read(n);
                pos += n;
            }
            Ok(LinearReadEvent::Record { .. }) => {}
            Err(e) => return Err(describe(&e, bytes, pos)),
        }
    }
    Ok(())
}

/// What failed, with the chunk it failed in when a chunk did.
fn describe(e: &McapError, bytes: &[u8], pos: usize) -> String {
    let chunk = || {
        chunk_at(bytes, pos).map_or_else(
            || format!("near byte {pos}"),
            |(k, (offset, len))| format!("in chunk {k} (bytes {offset}..{})", offset + len),
        )
    };
    match e {
        McapError::BadChunkCrc { saved, calculated } => format!(
            "{}: the records' CRC is {calculated:08x}, the chunk says {saved:08x}: the bag is corrupt",
            chunk()
        ),
        McapError::BadDataCrc { saved, calculated } => format!(
            "the data section's CRC is {calculated:08x}, its data end record says {saved:08x}: the bag is corrupt"
        ),
        McapError::BadSummaryCrc { saved, calculated } => format!(
            "the summary section's CRC is {calculated:08x}, its footer says {saved:08x}: the bag is corrupt"
        ),
        other => format!("at byte {pos} ({}): {other}", chunk()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_walk_finds_no_chunk_in_bytes_that_are_not_mcap() {
        assert!(chunk_spans(b"").is_empty());
        assert!(chunk_spans(&[0xff; 40]).is_empty());
        assert!(check(b"not an mcap file at all").is_err());
    }
}
