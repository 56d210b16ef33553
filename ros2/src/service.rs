//! [`ServiceClient`]: a minimal raw ROS 2 service client (the Mech-Eye capture service).
//!
//! A ROS 2 service on DDS is two topics, `rq/<service>Request` (type
//! `pkg::srv::dds_::Name_Request_`) and `rr/<service>Reply` (`Name_Response_`), reliable,
//! volatile, keep last 10 (`rmw_qos_profile_services_default`). How a reply finds its request
//! depends on the server's middleware ([`ServiceMapping`]):
//!
//! - [`ServiceMapping::Cyclone`] (rmw_cyclonedds): request and reply payloads start with the
//!   16-byte header `{ uint64 client_id; int64 sequence }` (little-endian, right after the
//!   encapsulation header); the server copies it into the reply. CDR alignment of the fields
//!   after it is unchanged (16 is a multiple of 8).
//! - [`ServiceMapping::FastDds`] (rmw_fastrtps, ROS 2's default middleware): no header; the
//!   reply carries the request's RTPS sample identity (writer GUID + sequence number) as its
//!   `related_sample_identity` inline QoS.
//!
//! Requests and responses are CDR with the encapsulation header, without the mapping's header
//! (`msgs`-style bytes in and out).

use std::time::{Duration, Instant};

use rustdds::bytes::Bytes;
use rustdds::mio1::{Events, Interest, Poll};
use rustdds::no_key::{DataReader, DataWriter};
use rustdds::{RTPSEntity, SampleIdentity, WriteOptionsBuilder};

use crate::error::Ros2Error;
use crate::graph::LocalEndpoints;
use crate::raw::{RawCdr, with_header};
use crate::subscription::READER_TOKEN;

/// Length of rmw_cyclonedds' request/reply header.
pub const CYCLONE_HEADER_LEN: usize = 16;

/// How replies are matched to requests (the server's ROS 2 middleware).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ServiceMapping {
    /// rmw_cyclonedds: a `{client_id, sequence}` header in the payload.
    Cyclone,
    /// rmw_fastrtps (ROS 2's default): the RTPS sample identity, echoed as the reply's
    /// related sample identity. Not yet tested against a Fast DDS server.
    FastDds,
}

/// A reply's payload and the request identity it says it answers (Fast DDS mapping).
type Reply = (Vec<u8>, Option<SampleIdentity>);

/// A raw client of one service.
pub struct ServiceClient {
    pub(crate) service: String,
    pub(crate) mapping: ServiceMapping,
    pub(crate) writer: DataWriter<Bytes, RawCdr>,
    pub(crate) reader: DataReader<Vec<u8>, RawCdr>,
    pub(crate) poll: Poll,
    pub(crate) events: Events,
    pub(crate) client_id: u64,
    pub(crate) next_sequence: i64,
    pub(crate) local: LocalEndpoints,
    pub(crate) guids: [[u8; 16]; 2],
}

impl std::fmt::Debug for ServiceClient {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ServiceClient")
            .field("service", &self.service)
            .field("mapping", &self.mapping)
            .finish()
    }
}

impl ServiceClient {
    pub(crate) fn new(
        service: String,
        mapping: ServiceMapping,
        writer: DataWriter<Bytes, RawCdr>,
        mut reader: DataReader<Vec<u8>, RawCdr>,
        local: LocalEndpoints,
    ) -> Result<ServiceClient, Ros2Error> {
        let poll_err = |source| Ros2Error::Poll {
            topic: service.clone(),
            source,
        };
        let poll = Poll::new().map_err(poll_err)?;
        poll.registry()
            .register(&mut reader, READER_TOKEN, Interest::READABLE)
            .map_err(poll_err)?;
        let writer_guid = writer.guid().to_bytes();
        let mut id = [0_u8; 8];
        id.copy_from_slice(&writer_guid[8..]);
        let guids = [writer_guid, reader.guid().to_bytes()];
        Ok(ServiceClient {
            service,
            mapping,
            writer,
            reader,
            poll,
            events: Events::with_capacity(4),
            // The last 8 GUID bytes (participant-unique part + entity id), as rmw_cyclonedds.
            client_id: u64::from_le_bytes(id),
            next_sequence: 1,
            local,
            guids,
        })
    }

    /// The service name.
    pub fn service(&self) -> &str {
        &self.service
    }

    /// Sends `request` (CDR with encapsulation header) and waits up to `timeout` for its
    /// response; `None` when none came in time.
    ///
    /// # Errors
    /// [`Ros2Error::PayloadTooShort`], [`Ros2Error::UnsupportedEncapsulation`],
    /// [`Ros2Error::Write`], [`Ros2Error::Read`], [`Ros2Error::Poll`],
    /// [`Ros2Error::ServiceReply`] (a reply too short for the mapping's header).
    pub fn call_raw(
        &mut self,
        request: &[u8],
        timeout: Duration,
    ) -> Result<Option<Vec<u8>>, Ros2Error> {
        let Some(&[b0, b1, _, _]) = request.get(..msgs::cdr::HEADER_LEN) else {
            return Err(Ros2Error::PayloadTooShort {
                topic: self.service.clone(),
                len: request.len(),
            });
        };
        if [b0, b1] != [0x00, 0x01] {
            return Err(Ros2Error::UnsupportedEncapsulation {
                topic: self.service.clone(),
                b0,
                b1,
            });
        }
        let sequence = self.next_sequence;
        self.next_sequence += 1;
        let header = self.cyclone_header(sequence);
        let payload = match self.mapping {
            ServiceMapping::Cyclone => {
                let mut p = Vec::with_capacity(request.len() + CYCLONE_HEADER_LEN);
                p.extend_from_slice(&request[..msgs::cdr::HEADER_LEN]);
                p.extend_from_slice(&header);
                p.extend_from_slice(&request[msgs::cdr::HEADER_LEN..]);
                p
            }
            ServiceMapping::FastDds => request.to_vec(),
        };
        let identity = self
            .writer
            .write_with_options(Bytes::from(payload), WriteOptionsBuilder::new().build())
            .map_err(|e| Ros2Error::Write {
                topic: self.service.clone(),
                reason: e.to_string(),
            })?;
        let deadline = Instant::now() + timeout;
        loop {
            while let Some(reply) = self.take_reply()? {
                if let Some(response) = self.match_reply(&reply.0, reply.1, &header, identity)? {
                    return Ok(Some(response));
                }
            }
            let now = Instant::now();
            if now >= deadline {
                return Ok(None);
            }
            let wait = (deadline - now).min(Duration::from_millis(50));
            match self.poll.poll(&mut self.events, Some(wait)) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(source) => {
                    return Err(Ros2Error::Poll {
                        topic: self.service.clone(),
                        source,
                    });
                }
            }
        }
    }

    fn cyclone_header(&self, sequence: i64) -> [u8; CYCLONE_HEADER_LEN] {
        let mut h = [0_u8; CYCLONE_HEADER_LEN];
        h[..8].copy_from_slice(&self.client_id.to_le_bytes());
        h[8..].copy_from_slice(&sequence.to_le_bytes());
        h
    }

    fn take_reply(&mut self) -> Result<Option<Reply>, Ros2Error> {
        let sample = self
            .reader
            .take_next_sample()
            .map_err(|e| Ros2Error::Read {
                topic: self.service.clone(),
                reason: e.to_string(),
            })?;
        Ok(sample.map(|s| {
            let related = s.sample_info().related_sample_identity();
            (s.into_value(), related)
        }))
    }

    /// The response in `reply` if it answers this request (`None`: someone else's reply).
    fn match_reply(
        &self,
        reply: &[u8],
        related: Option<SampleIdentity>,
        header: &[u8; CYCLONE_HEADER_LEN],
        identity: SampleIdentity,
    ) -> Result<Option<Vec<u8>>, Ros2Error> {
        match self.mapping {
            ServiceMapping::Cyclone => {
                let h = msgs::cdr::HEADER_LEN;
                let (Some(kind), Some(got), Some(rest)) = (
                    reply.get(..2),
                    reply.get(h..h + CYCLONE_HEADER_LEN),
                    reply.get(h + CYCLONE_HEADER_LEN..),
                ) else {
                    return Err(Ros2Error::ServiceReply {
                        service: self.service.clone(),
                        len: reply.len(),
                    });
                };
                Ok((got == header).then(|| with_header([kind[0], kind[1]], rest)))
            }
            ServiceMapping::FastDds => Ok((related == Some(identity)).then(|| reply.to_vec())),
        }
    }
}

impl Drop for ServiceClient {
    fn drop(&mut self) {
        for g in &self.guids {
            self.local.remove(g);
        }
    }
}
