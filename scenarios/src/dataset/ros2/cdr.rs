//! CDR as ROS 2 puts it in a bag: a 4-byte encapsulation header (`00 01 00 00`: plain CDR,
//! little-endian; `00 00`: big-endian) and the message, aligned from the byte after the header.
//! Encoding and decoding are `cdr-encoding`'s (the serde CDR of RustDDS and ros2-client).

use byteorder::{BigEndian, LittleEndian};

use super::messages::{Header, RosMessage};

/// Plain CDR, little-endian (big-endian is `00 00 00 00`).
const CDR_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// `msg` as a bag's message data (little-endian).
pub fn encode<T: RosMessage>(msg: &T) -> Vec<u8> {
    let mut out = CDR_LE.to_vec();
    // Writing into a `Vec` cannot fail, and every type here is CDR-representable.
    out.extend(
        cdr_encoding::to_vec::<T, LittleEndian>(msg)
            .unwrap_or_else(|e| panic!("CDR of {}: {e}", T::TYPE)),
    );
    out
}

/// A bag's message data as `T`: the header says the byte order; the message must fill the data
/// up to at most 3 bytes of final padding.
pub fn decode<T: RosMessage>(data: &[u8]) -> Result<T, String> {
    let (header, body) = data.split_at_checked(4).ok_or_else(|| {
        format!(
            "{} bytes: shorter than the 4-byte CDR encapsulation header",
            data.len()
        )
    })?;
    let (msg, used) = match header[..2] {
        [0x00, 0x01] => cdr_encoding::from_bytes::<T, LittleEndian>(body),
        [0x00, 0x00] => cdr_encoding::from_bytes::<T, BigEndian>(body),
        _ => {
            return Err(format!(
                "encapsulation {:02x} {:02x}: only plain CDR (00 00, 00 01) is read",
                header[0], header[1]
            ));
        }
    }
    .map_err(|e| format!("not a {}: {e}", T::TYPE))?;
    if body.len() - used > 3 {
        return Err(format!(
            "not a {}: {} bytes left over after the message",
            T::TYPE,
            body.len() - used
        ));
    }
    Ok(msg)
}

/// The `std_msgs/msg/Header` a stamped message begins with (`Image`, `Imu`, `PoseStamped`, …),
/// without decoding the rest.
pub fn decode_header(data: &[u8]) -> Result<Header, String> {
    let body = data
        .get(4..)
        .ok_or_else(|| "shorter than the 4-byte CDR encapsulation header".to_string())?;
    let header = match data[..2] {
        [0x00, 0x01] => cdr_encoding::from_bytes::<Header, LittleEndian>(body),
        [0x00, 0x00] => cdr_encoding::from_bytes::<Header, BigEndian>(body),
        _ => return Err("not plain CDR".into()),
    };
    header
        .map(|(h, _)| h)
        .map_err(|e| format!("no std_msgs/msg/Header at its start: {e}"))
}

#[cfg(test)]
mod tests {
    use super::super::messages::{Header, Image, Imu, Time};
    use super::*;

    #[test]
    fn header_and_alignment_follow_ros2() {
        let img = Image {
            header: Header {
                stamp: Time { sec: 1, nanosec: 2 },
                frame_id: "cam0".into(),
            },
            height: 1,
            width: 3,
            encoding: "mono8".into(),
            is_bigendian: 0,
            step: 3,
            data: vec![7, 8, 9],
        };
        let bytes = encode(&img);
        // Header, sec, nanosec, "cam0\0" (length 5), padded to 4, height, width...
        assert_eq!(&bytes[..4], &CDR_LE);
        assert_eq!(&bytes[4..12], &[1, 0, 0, 0, 2, 0, 0, 0]);
        assert_eq!(&bytes[12..21], &[5, 0, 0, 0, b'c', b'a', b'm', b'0', 0]);
        assert_eq!(&bytes[21..24], &[0, 0, 0]);
        assert_eq!(&bytes[24..28], &[1, 0, 0, 0]);
        assert_eq!(decode::<Image>(&bytes).unwrap(), img);
        assert_eq!(decode_header(&bytes).unwrap(), img.header);
        // Truncated, wrong header, wrong type: errors, never panics.
        assert!(decode::<Image>(&bytes[..20]).is_err());
        assert!(decode::<Image>(&[1, 2]).is_err());
        assert!(decode::<Imu>(&bytes).is_err());
    }
}
