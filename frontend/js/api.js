// The REST contract v1 over fetch: bearer token, JSON in and out, Error(detail) on 4xx/5xx.

const BASE = "/api/v1";
const TOKEN_KEY = "gsfm.token";
const USER_KEY = "gsfm.username";

export class ApiError extends Error {
  constructor(status, detail) {
    super(detail);
    this.status = status;
  }
}

export const session = {
  get token() { return localStorage.getItem(TOKEN_KEY); },
  get username() { return localStorage.getItem(USER_KEY); },
  save(token, username) {
    localStorage.setItem(TOKEN_KEY, token);
    localStorage.setItem(USER_KEY, username);
  },
  clear() {
    localStorage.removeItem(TOKEN_KEY);
    localStorage.removeItem(USER_KEY);
  },
};

// Called with the ApiError when the server answers 401, so the app can ask to sign in again.
let onUnauthorized = () => {};
export function setUnauthorizedHandler(handler) { onUnauthorized = handler; }

function authHeaders(extra = {}) {
  const token = session.token;
  return token ? { Authorization: `Bearer ${token}`, ...extra } : extra;
}

async function errorOf(response) {
  let detail = `${response.status} ${response.statusText}`;
  try {
    const body = await response.json();
    if (typeof body.detail === "string") detail = body.detail;
    else if (body.detail) detail = JSON.stringify(body.detail);
  } catch { /* not JSON: keep the status line */ }
  const error = new ApiError(response.status, detail);
  if (response.status === 401) onUnauthorized(error);
  return error;
}

// request(method, path, {json, form, headers}) -> {data, response}
export async function request(method, path, { json, form, headers = {} } = {}) {
  const init = { method, headers: authHeaders(headers) };
  if (json !== undefined) {
    init.headers["Content-Type"] = "application/json";
    init.body = JSON.stringify(json);
  } else if (form !== undefined) {
    init.body = form;
  }
  const response = await fetch(BASE + path, init);
  if (!response.ok) throw await errorOf(response);
  const data = response.status === 204 ? null : await response.json().catch(() => null);
  return { data, response };
}

export const get = async (path) => (await request("GET", path)).data;
export const post = async (path, json) => (await request("POST", path, { json })).data;
export const put = async (path, json) => (await request("PUT", path, { json })).data;
export const del = async (path) => (await request("DELETE", path)).data;

export async function signIn(username, password) {
  const form = new URLSearchParams({ username, password });
  const { data } = await request("POST", "/auth/token", { form });
  session.save(data.access_token, username);
  return data;
}

export const signUp = (username, password) => post("/users", { username, password });

// A binary resource (thumbnail, image file) as an object URL, since <img> cannot send a token.
export async function blobUrl(path) {
  const response = await fetch(BASE + path, { headers: authHeaders() });
  if (!response.ok) throw await errorOf(response);
  return URL.createObjectURL(await response.blob());
}

// Multipart upload with progress(fraction); XHR because fetch reports no upload progress.
export function upload(path, formData, progress) {
  return new Promise((resolve, reject) => {
    const xhr = new XMLHttpRequest();
    xhr.open("POST", BASE + path);
    const token = session.token;
    if (token) xhr.setRequestHeader("Authorization", `Bearer ${token}`);
    xhr.upload.onprogress = (e) => { if (e.lengthComputable) progress(e.loaded / e.total); };
    xhr.onload = () => {
      let body = null;
      try { body = JSON.parse(xhr.responseText); } catch { /* keep null */ }
      if (xhr.status >= 200 && xhr.status < 300) resolve(body);
      else reject(new ApiError(xhr.status, body?.detail ?? `${xhr.status} ${xhr.statusText}`));
    };
    xhr.onerror = () => reject(new ApiError(0, "network error during upload"));
    xhr.send(formData);
  });
}
