//! A ROS 2 bag in MCAP, written as rosbag2 writes one: profile `ros2`, one schema per message
//! type (encoding `ros2msg`, the complete definition), one channel per topic (message encoding
//! `cdr`, with rosbag2's `offered_qos_profiles` metadata, transient-local for `/tf_static`),
//! messages whose log time is their header stamp. Uncompressed chunks: every MCAP reader takes
//! them without a decompressor. Same messages in, same bytes out.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use super::cdr;
use super::messages::RosMessage;

/// rosbag2's QoS profile of a recorded topic: reliable, volatile (keep last).
const QOS_VOLATILE: &str = "- history: 3\n  depth: 0\n  reliability: 1\n  durability: 2\n  deadline:\n    sec: 9223372036\n    nsec: 854775807\n  lifespan:\n    sec: 9223372036\n    nsec: 854775807\n  liveliness: 1\n  liveliness_lease_duration:\n    sec: 9223372036\n    nsec: 854775807\n  avoid_ros_namespace_conventions: false";
/// The same, transient-local (latched), as `/tf_static` is published.
const QOS_LATCHED: &str = "- history: 3\n  depth: 0\n  reliability: 1\n  durability: 1\n  deadline:\n    sec: 9223372036\n    nsec: 854775807\n  lifespan:\n    sec: 9223372036\n    nsec: 854775807\n  liveliness: 1\n  liveliness_lease_duration:\n    sec: 9223372036\n    nsec: 854775807\n  avoid_ros_namespace_conventions: false";

/// An MCAP writer for ROS 2 messages.
pub struct BagWriter {
    path: PathBuf,
    writer: mcap::Writer<BufWriter<File>>,
    schemas: BTreeMap<&'static str, u16>,
    channels: BTreeMap<String, (u16, &'static str)>,
    sequence: u32,
}

impl BagWriter {
    /// Creates `path` (its folder too).
    pub fn create(path: &Path) -> Result<Self, String> {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        }
        let file = File::create(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let writer = mcap::WriteOptions::new()
            .profile("ros2")
            .compression(None)
            .create(BufWriter::new(file))
            .map_err(|e| format!("{}: {e}", path.display()))?;
        Ok(Self {
            path: path.to_path_buf(),
            writer,
            schemas: BTreeMap::new(),
            channels: BTreeMap::new(),
            sequence: 0,
        })
    }

    fn error(&self, e: impl std::fmt::Display) -> String {
        format!("{}: {e}", self.path.display())
    }

    /// Writes `msg` on `topic` with log time `t_ns` (ns; the bag's clock). A topic carries one
    /// type.
    pub fn write<T: RosMessage>(&mut self, topic: &str, t_ns: i64, msg: &T) -> Result<(), String> {
        let channel = match self.channels.get(topic) {
            Some(&(id, ty)) if ty == T::TYPE => id,
            Some(&(_, ty)) => {
                return Err(self.error(format!(
                    "topic {topic} carries {ty}, cannot write a {} on it",
                    T::TYPE
                )));
            }
            None => {
                let schema = match self.schemas.get(T::TYPE) {
                    Some(&id) => id,
                    None => {
                        let id = self
                            .writer
                            .add_schema(T::TYPE, "ros2msg", T::definition().as_bytes())
                            .map_err(|e| self.error(e))?;
                        self.schemas.insert(T::TYPE, id);
                        id
                    }
                };
                let qos = if topic == "/tf_static" {
                    QOS_LATCHED
                } else {
                    QOS_VOLATILE
                };
                let metadata = BTreeMap::from([("offered_qos_profiles".into(), qos.into())]);
                let id = self
                    .writer
                    .add_channel(schema, topic, "cdr", &metadata)
                    .map_err(|e| self.error(e))?;
                self.channels.insert(topic.into(), (id, T::TYPE));
                id
            }
        };
        let log_time = u64::try_from(t_ns)
            .map_err(|_| self.error(format!("{topic}: negative stamp {t_ns} ns")))?;
        let header = mcap::records::MessageHeader {
            channel_id: channel,
            sequence: self.sequence,
            log_time,
            publish_time: log_time,
        };
        self.sequence += 1;
        self.writer
            .write_to_known_channel(&header, &cdr::encode(msg))
            .map_err(|e| self.error(e))
    }

    /// Attaches a file (`name`, media type, bytes), as a calibration travels with a recording.
    pub fn attach(&mut self, name: &str, media_type: &str, data: &[u8]) -> Result<(), String> {
        let attachment = mcap::Attachment {
            log_time: 0,
            create_time: 0,
            name: name.into(),
            media_type: media_type.into(),
            data: std::borrow::Cow::Borrowed(data),
        };
        self.writer.attach(&attachment).map_err(|e| self.error(e))
    }

    /// Writes the summary and closes the file.
    pub fn finish(mut self) -> Result<(), String> {
        self.writer.finish().map_err(|e| self.error(e))?;
        let path = self.path;
        self.writer
            .into_inner()
            .flush()
            .map_err(|e| format!("{}: {e}", path.display()))
    }
}
