//! The layout server's HTTP side (axum on a one-thread tokio runtime): every request is read
//! whole (its body up to a limit), checked for a loopback `Host` and `Origin`, and handed to one
//! handler at a time on a blocking thread; its [`Reply`] goes back with the headers every
//! answer carries. Bad HTTP never reaches the handler (hyper answers it), and nothing a client
//! sends stops the server: only the stop flag (Ctrl-C, SIGTERM) does.

use axum::body::Body;
use axum::extract::Request;
use axum::http::{HeaderValue, StatusCode, header};
use axum::response::Response;
use std::net::TcpListener;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// The largest request body read (an edit is a few hundred bytes).
const MAX_BODY: usize = 64 << 10;

/// A request as the handler sees it.
pub struct Incoming {
    pub post: bool,
    /// The path and query.
    pub url: String,
    pub body: String,
}

/// An answer: status, content type, body and any headers of its own.
pub struct Reply {
    pub status: u16,
    pub kind: &'static str,
    pub body: Vec<u8>,
    pub headers: Vec<(&'static str, String)>,
}

impl Reply {
    pub fn text(status: u16, message: &str) -> Self {
        Self {
            status,
            kind: "text/plain; charset=utf-8",
            body: format!("{message}\n").into_bytes(),
            headers: Vec::new(),
        }
    }

    pub fn json(value: &serde_json::Value) -> Self {
        Self::json_text(value.to_string())
    }

    pub fn json_text(text: String) -> Self {
        Self {
            status: 200,
            kind: "application/json",
            body: text.into_bytes(),
            headers: Vec::new(),
        }
    }

    /// `{"error": message}` with `status`.
    pub fn error(status: u16, message: &str) -> Self {
        Self {
            status,
            ..Self::json(&serde_json::json!({ "error": message }))
        }
    }

    pub fn bytes(kind: &'static str, body: Vec<u8>) -> Self {
        Self {
            status: 200,
            kind,
            body,
            headers: Vec::new(),
        }
    }

    /// The reply with `name: value` added (a value that is not a valid header is left out).
    pub fn with_header(mut self, name: &'static str, value: String) -> Self {
        self.headers.push((name, value));
        self
    }
}

/// Serves `listener` (bound to a loopback address at `port`) until `stop` is set, answering
/// with `handler`.
pub fn serve(
    listener: TcpListener,
    port: u16,
    stop: &'static AtomicBool,
    handler: impl FnMut(Incoming) -> Reply + Send + 'static,
) -> anyhow::Result<()> {
    listener.set_nonblocking(true)?;
    let handler = Arc::new(Mutex::new(handler));
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()?;
    runtime.block_on(async move {
        let listener = tokio::net::TcpListener::from_std(listener)?;
        let app = axum::Router::new().fallback(move |request: Request| {
            let handler = handler.clone();
            async move { answer(request, port, handler).await }
        });
        axum::serve(listener, app)
            .with_graceful_shutdown(async move {
                while !stop.load(Ordering::SeqCst) {
                    tokio::time::sleep(Duration::from_millis(200)).await;
                }
            })
            .await?;
        anyhow::Ok(())
    })
}

async fn answer<H: FnMut(Incoming) -> Reply + Send + 'static>(
    request: Request,
    port: u16,
    handler: Arc<Mutex<H>>,
) -> Response {
    let reply = if !loopback(&request, port) {
        Reply::text(
            403,
            "rift layout answers only requests to its own loopback address",
        )
    } else {
        let post = request.method() == axum::http::Method::POST;
        let get = request.method() == axum::http::Method::GET;
        let url = request
            .uri()
            .path_and_query()
            .map_or("/".into(), |p| p.to_string());
        match axum::body::to_bytes(request.into_body(), MAX_BODY).await {
            _ if !post && !get => Reply::text(405, "only GET and POST are served"),
            Err(_) => Reply::text(413, "the body is larger than an edit can be"),
            Ok(bytes) => match String::from_utf8(bytes.to_vec()) {
                Err(_) => Reply::text(400, "the body is not UTF-8 text"),
                Ok(body) => {
                    let incoming = Incoming { post, url, body };
                    // One request at a time, off the runtime's thread (a check render takes
                    // seconds).
                    let handled = tokio::task::spawn_blocking(move || {
                        let mut handler = handler.lock().unwrap_or_else(|e| e.into_inner());
                        handler(incoming)
                    })
                    .await;
                    handled.unwrap_or_else(|_| Reply::text(500, "the request failed"))
                }
            },
        }
    };
    let mut response = Response::new(Body::from(reply.body));
    *response.status_mut() =
        StatusCode::from_u16(reply.status).unwrap_or(StatusCode::INTERNAL_SERVER_ERROR);
    let headers = response.headers_mut();
    headers.insert(header::CONTENT_TYPE, HeaderValue::from_static(reply.kind));
    headers.insert(
        header::X_CONTENT_TYPE_OPTIONS,
        HeaderValue::from_static("nosniff"),
    );
    for (name, value) in reply.headers {
        if let Ok(value) = HeaderValue::from_str(&value) {
            headers.insert(name, value);
        }
    }
    response
}

/// True when the request's `Host` (and `Origin`, if any) name this server's loopback address,
/// so another site open in the same browser cannot read the shot (DNS rebinding).
fn loopback(request: &Request, port: u16) -> bool {
    let allowed = |authority: &str| {
        ["127.0.0.1", "localhost", "[::1]"]
            .iter()
            .any(|host| authority == format!("{host}:{port}"))
    };
    let header = |name: header::HeaderName| {
        request
            .headers()
            .get(name)
            .map(|v| v.to_str().unwrap_or("").to_owned())
    };
    let host_ok = header(header::HOST).is_some_and(|h| allowed(&h));
    let origin_ok =
        header(header::ORIGIN).is_none_or(|o| o.strip_prefix("http://").is_some_and(allowed));
    host_ok && origin_ok
}
