use tokio::io::{AsyncRead, AsyncWrite};
use tokio_tungstenite::tungstenite::handshake::server;
use tokio_tungstenite::tungstenite::http::HeaderValue;
use tokio_tungstenite::{WebSocketStream, tungstenite};

pub(crate) const SUBPROTOCOL: &str = "foxglove.sdk.v1";

/// The same protocol's earlier name: the only one offered by `@foxglove/ws-protocol`'s client,
/// Foxglove Studio up to 1.87 and Lichtblick before December 2025.
const LEGACY_SUBPROTOCOL: &str = "foxglove.websocket.v1";

/// Add the subprotocol header to the response if the client requested it, answering with the name
/// the client offered (ours first). If the client requests subprotocols which contain neither
/// name, or does not include the expected header, return a 400.
pub(crate) async fn do_handshake<S: AsyncRead + AsyncWrite + Unpin>(
    stream: S,
) -> Result<WebSocketStream<S>, tungstenite::Error> {
    tokio_tungstenite::accept_hdr_async(
        stream,
        #[allow(clippy::result_large_err)]
        |req: &server::Request, mut res: server::Response| {
            let offered = |name: &str| {
                req.headers()
                    .get_all("sec-websocket-protocol")
                    .iter()
                    .any(|h| h.to_str().unwrap_or_default().split(',').any(|v| v.trim() == name))
            };
            if let Some(chosen) = [SUBPROTOCOL, LEGACY_SUBPROTOCOL]
                .into_iter()
                .find(|name| offered(name))
            {
                res.headers_mut()
                    .insert("sec-websocket-protocol", HeaderValue::from_static(chosen));
                return Ok(res);
            }

            Err(server::Response::builder()
                .status(400)
                .body(Some(
                    "Missing expected sec-websocket-protocol header".into(),
                ))
                .unwrap())
        },
    )
    .await
}
