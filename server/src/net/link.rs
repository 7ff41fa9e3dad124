//! One game client's connection, whichever way it came: raw QUIC (ALPN
//! `inertia`, the SDK) or a WebTransport session over HTTP/3 (ALPN `h3`, a
//! browser). The game protocol on top is the same either way: one
//! bidirectional control stream that the client opens, snapshots and
//! inputs as datagrams.

use bytes::Bytes;

/// A game client's connection.
#[derive(Debug, Clone)]
pub enum Link {
    /// Raw QUIC with the game's ALPN.
    Quic(quinn::Connection),
    /// A WebTransport session (its datagrams and streams carry the
    /// session's id, which the session adds and strips). Boxed: it is
    /// large beside a connection handle.
    WebTransport(Box<web_transport_quinn::Session>),
}

/// The server's half of the control stream.
#[derive(Debug)]
pub enum LinkSend {
    /// On raw QUIC.
    Quic(quinn::SendStream),
    /// In a WebTransport session.
    WebTransport(web_transport_quinn::SendStream),
}

/// The client's half of the control stream.
#[derive(Debug)]
pub enum LinkRecv {
    /// On raw QUIC.
    Quic(quinn::RecvStream),
    /// In a WebTransport session.
    WebTransport(web_transport_quinn::RecvStream),
}

/// Why a link failed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum LinkError {
    /// The connection is gone (closed, timed out, reset).
    #[error("{0}")]
    Lost(String),
    /// The stream failed while the connection lives on.
    #[error("{0}")]
    Stream(String),
}

fn lost_or_stream(lost: bool, e: impl std::fmt::Display) -> LinkError {
    if lost {
        LinkError::Lost(e.to_string())
    } else {
        LinkError::Stream(e.to_string())
    }
}

impl Link {
    /// The QUIC connection underneath.
    pub fn quic(&self) -> &quinn::Connection {
        match self {
            Link::Quic(c) => c,
            Link::WebTransport(s) => s,
        }
    }

    /// The peer's address.
    pub fn remote_address(&self) -> std::net::SocketAddr {
        self.quic().remote_address()
    }

    /// A number for the connection, unique while it lives.
    pub fn stable_id(&self) -> usize {
        self.quic().stable_id()
    }

    /// True for a browser's WebTransport session.
    pub fn is_web_transport(&self) -> bool {
        matches!(self, Link::WebTransport(_))
    }

    /// Waits for the client to open its control stream.
    pub async fn accept_bi(&self) -> Result<(LinkSend, LinkRecv), LinkError> {
        match self {
            Link::Quic(c) => c
                .accept_bi()
                .await
                .map(|(s, r)| (LinkSend::Quic(s), LinkRecv::Quic(r)))
                .map_err(|e| LinkError::Lost(e.to_string())),
            Link::WebTransport(s) => s
                .accept_bi()
                .await
                .map(|(s, r)| (LinkSend::WebTransport(s), LinkRecv::WebTransport(r)))
                .map_err(|e| LinkError::Lost(e.to_string())),
        }
    }

    /// The next datagram from the client.
    pub async fn read_datagram(&self) -> Result<Bytes, LinkError> {
        match self {
            Link::Quic(c) => c
                .read_datagram()
                .await
                .map_err(|e| LinkError::Lost(e.to_string())),
            Link::WebTransport(s) => s
                .read_datagram()
                .await
                .map_err(|e| LinkError::Lost(e.to_string())),
        }
    }

    /// Sends a datagram; false when it could not be queued.
    pub fn send_datagram(&self, bytes: Bytes) -> bool {
        match self {
            Link::Quic(c) => c.send_datagram(bytes).is_ok(),
            Link::WebTransport(s) => s.send_datagram(bytes).is_ok(),
        }
    }

    /// The largest datagram the path takes now, bytes (for a session, less
    /// its header).
    pub fn max_datagram_size(&self) -> Option<usize> {
        match self {
            Link::Quic(c) => c.max_datagram_size(),
            Link::WebTransport(s) => Some(s.max_datagram_size()).filter(|&n| n > 0),
        }
    }

    /// Closes with an application `code` and `reason` (a session first
    /// tells the browser, which shows them on `WebTransport.closed`).
    pub fn close(&self, code: u32, reason: &[u8]) {
        match self {
            Link::Quic(c) => c.close(code.into(), reason),
            Link::WebTransport(s) => s.close(code, reason),
        }
    }
}

impl LinkSend {
    /// Writes some of `buf`; how much.
    pub async fn write(&mut self, buf: &[u8]) -> Result<usize, LinkError> {
        match self {
            LinkSend::Quic(s) => s
                .write(buf)
                .await
                .map_err(|e| lost_or_stream(matches!(e, quinn::WriteError::ConnectionLost(_)), e)),
            LinkSend::WebTransport(s) => s.write(buf).await.map_err(|e| {
                lost_or_stream(
                    matches!(e, web_transport_quinn::WriteError::SessionError(_)),
                    e,
                )
            }),
        }
    }

    /// Writes all of `buf`.
    pub async fn write_all(&mut self, mut buf: &[u8]) -> Result<(), LinkError> {
        while !buf.is_empty() {
            let n = self.write(buf).await?;
            buf = &buf[n..];
        }
        Ok(())
    }

    /// Ends the stream once what was written has gone.
    pub fn finish(&mut self) {
        let _ = match self {
            LinkSend::Quic(s) => s.finish().is_ok(),
            LinkSend::WebTransport(s) => s.finish().is_ok(),
        };
    }

    /// Waits until the peer has read everything (or stopped the stream).
    pub async fn stopped(&mut self) {
        let _ = match self {
            LinkSend::Quic(s) => s.stopped().await.is_ok(),
            LinkSend::WebTransport(s) => s.stopped().await.is_ok(),
        };
    }
}

impl LinkRecv {
    /// Reads into `buf`; `None` once the client finished the stream.
    pub async fn read(&mut self, buf: &mut [u8]) -> Result<Option<usize>, LinkError> {
        match self {
            LinkRecv::Quic(r) => r
                .read(buf)
                .await
                .map_err(|e| lost_or_stream(matches!(e, quinn::ReadError::ConnectionLost(_)), e)),
            LinkRecv::WebTransport(r) => r.read(buf).await.map_err(|e| {
                lost_or_stream(
                    matches!(e, web_transport_quinn::ReadError::SessionError(_)),
                    e,
                )
            }),
        }
    }
}
